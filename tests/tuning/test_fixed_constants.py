"""Constants a preset sets outside the search space (the route ties): a search that starts from the preset
holds them, names its study by them and exports them (TuneConfig.fixed, tuning.space.FIXED_PRIORS)."""

from __future__ import annotations

import pytest

from ndrql.errors import NdrqlError
from ndrql.planning.config import PriorConfig
from ndrql.planning.methods import METHODS
from ndrql.planning.preset import PRESET_FIELDS, load_preset
from ndrql.tuning import space as S
from ndrql.tuning.report import best_setting
from ndrql.tuning.study import TuneConfig, start_params, study_name

ROUTE = (("region_dilation", 1.0), ("guideline_ties", 0.3))


def test_every_preset_prior_is_searched_or_fixed():
    searched = {f for m in METHODS for p in S.search_space(m) if p.part == "priors" for f in p.fields}
    assert set(S.FIXED_PRIORS) == set(PRESET_FIELDS["priors"]) - searched


def test_fixed_priors_of_the_general_preset():
    assert S.fixed_priors(PriorConfig()) == ()
    general = load_preset("general")
    beyond = (("region_distance", 1.0), ("thd_tail", 1.0))  # Eq. 6's distance through the region, Eq. 7's tail
    assert S.fixed_priors(general.configs("NDR-QL", grid=50)[1]) == ROUTE + beyond
    assert S.fixed_priors(general.configs("NDR-QL", grid=100)[1]) == (("guideline_ties", 0.3),) + beyond
    assert S.fixed_priors(general.configs("IQL", grid=50)[1]) == ()


def test_a_search_holds_and_names_its_fixed_constants():
    plain, fixed = TuneConfig("NDR-QL"), TuneConfig("NDR-QL", fixed=ROUTE)
    assert fixed.base_configs()[1] == PriorConfig(region_dilation=1, guideline_ties=0.3)
    assert plain.base_configs()[1] == PriorConfig()
    keys = ["tune-g50-1", "tune-g50-2"]
    assert study_name(plain, keys, "w") != study_name(fixed, keys, "w")
    assert study_name(fixed, keys, "w") == study_name(TuneConfig("NDR-QL", fixed=ROUTE), keys, "w")


@pytest.mark.parametrize("fixed, match", [((("r_max", 3.0),), "r_max is searched"),
                                          ((("guideline_ties", 2.0),), "guideline_ties")])
def test_bad_fixed_constants_are_refused(fixed, match):
    with pytest.raises(NdrqlError, match=match):
        TuneConfig("NDR-QL", fixed=fixed)


def test_trial_one_takes_the_preset_entry_of_the_searched_grid():
    general = load_preset("general")
    at_100 = start_params(TuneConfig("NDR-QL", start_from="general", grid=100))
    expected = S.params_of("NDR-QL", *general.configs("NDR-QL", grid=100))
    bounds = {p.name: (p.low, p.high) for p in S.search_space("NDR-QL")}
    assert at_100 == {k: min(max(v, bounds[k][0]), bounds[k][1]) for k, v in expected.items()}
    assert at_100 != start_params(TuneConfig("NDR-QL", start_from="general", grid=50))


def test_the_best_trial_is_exported_with_the_fixed_constants():
    optuna = pytest.importorskip("optuna")
    study = optuna.create_study()
    params = {p.name: p.low for p in S.search_space("NDR-QL")}
    study.add_trial(optuna.trial.create_trial(params=params, distributions=S.distributions("NDR-QL"), value=1.0,
                                              user_attrs={"c_ratio": 0.0, "c_not_converged": 0.0}))
    setting, bt = best_setting(study, "NDR-QL", TuneConfig("NDR-QL", fixed=ROUTE).base_configs()[1])
    assert bt is not None and setting.priors.guideline_ties == 0.3 and setting.priors.region_dilation == 1
    assert setting.priors.r_max == S.R_MAX.low
    assert best_setting(study, "NDR-QL")[0].priors.guideline_ties == 0.0  # without: the SPEC's
