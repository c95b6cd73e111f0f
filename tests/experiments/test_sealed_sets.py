"""Seed ranges, the registry's roles, the refusals of sealed sets and evaluation seeds, and no duplicate
map or problem between the training sets, the development sets and the sealed sets."""

from __future__ import annotations

import json
from collections import Counter

import pytest

from ndrql.dataset.generated import GeneratedSet, check_training_set, generate_set
from ndrql.dataset.mixture import SourceSpec, generated_source
from ndrql.errors import NdrqlError
from ndrql.experiments.eval_sets import (NOT_FOR_TUNING, eval_set, eval_spec, map_digest, parse_registry,
                                         problem_digest, recorded_digests, registry, sealed_names, set_record,
                                         tuning_spec, verify_seal)
from ndrql.limits import DEVELOPMENT_SEEDS, SEALED_SEEDS, TRAINING_SEEDS, check_training_seed, seed_role
from ndrql.synth.generate import SetSpec
from tests.helpers.cli import assert_one_line_error, run_cli

FAMS = ["blocks", "maze"]


def test_seed_ranges_are_adjacent_and_each_seed_has_one_role():
    assert TRAINING_SEEDS.stop == DEVELOPMENT_SEEDS.start == 900_000
    assert DEVELOPMENT_SEEDS.stop == SEALED_SEEDS.start == 950_000 and SEALED_SEEDS.stop == 1_000_000
    assert [seed_role(s) for s in (0, 899_999, 900_000, 949_999, 950_000, 999_999, 1_000_000)] == \
        ["training", "training", "development", "development", "sealed", "sealed", "unassigned"]
    assert check_training_seed(899_999) == 899_999
    for bad in (900_001, 950_001, 1_000_000):
        with pytest.raises(ValueError, match="not a training seed"):
            check_training_seed(bad)


def test_the_registry_gives_every_set_a_role_that_matches_its_seed():
    sets = registry()
    assert {"transfer", "select", "tune", "transfer-small", "sealed"} <= set(sets)
    for s in sets.values():
        assert seed_role(s.spec.seed) == s.role
    assert "sealed" in sealed_names() and "transfer" not in sealed_names()
    assert sets["sealed"].spec.to_dict() == {**sets["transfer"].spec.to_dict(), "seed": 950001}


def _doc(**sets) -> dict:
    return {"sets": {k: {"families": FAMS, "sizes": [96], "count": 4, **v} for k, v in sets.items()}}


@pytest.mark.parametrize("entry,needle", [
    ({"role": "sealed", "seed": 900_010}, "its seed 900010 is a development seed"),
    ({"role": "development", "seed": 950_010}, "its seed 950010 is a sealed seed"),
    ({"role": "development", "seed": 12}, "is a training seed"),
    ({"role": "secret", "seed": 950_010}, "role 'secret'"),
    ({"seed": 950_010}, "role None"),
])
def test_a_role_that_does_not_match_the_seed_range_is_refused(entry, needle):
    with pytest.raises(NdrqlError, match=needle):
        parse_registry(_doc(x=entry))


def test_two_sets_with_one_seed_are_refused():
    with pytest.raises(NdrqlError, match="share a seed"):
        parse_registry(_doc(a={"role": "development", "seed": 900_500}, b={"role": "development", "seed": 900_500}))


def test_sealed_sets_are_refused_to_everything_but_the_release():
    with pytest.raises(NdrqlError, match="'sealed' is sealed: only `ndrql reproduce release`"):
        eval_spec("sealed")
    assert eval_spec("sealed", release=True).seed == 950_001
    with pytest.raises(NdrqlError, match="sealed"):  # a sealed seed outside the registry too
        eval_set(SetSpec(("blocks",), (96,), 2, 950_777), progress=False)
    with pytest.raises(NdrqlError, match="sealed"):
        tuning_spec("sealed")
    for name in NOT_FOR_TUNING:
        with pytest.raises(NdrqlError, match="tune on 'tune'"):
            tuning_spec(name)
    assert tuning_spec("tune").seed == 900_004


def test_training_data_refuses_evaluation_seeds(tmp_path):
    with pytest.raises(NdrqlError, match="not a training seed"):
        generate_set(tmp_path / "a", SetSpec(("blocks",), (96,), 2, 900_003), progress=False)
    with pytest.raises(NdrqlError, match="evaluation sets take seeds"):
        generate_set(tmp_path / "b", SetSpec(("blocks",), (96,), 2, 5), progress=False, purpose="evaluation")
    # an evaluation-seeded set on disk is refused as a training source
    root = generate_set(tmp_path / "c", SetSpec(("blocks",), (96,), 2, 900_999), progress=False, purpose="evaluation")
    with pytest.raises(NdrqlError, match="cannot be a training source"):
        check_training_set(GeneratedSet.load(root))
    with pytest.raises(NdrqlError, match="cannot be a training source"):
        generated_source(SourceSpec(str(root), 1.0))


@pytest.mark.parametrize("args,needle", [
    (("data", "generate", "--family", "blocks", "--count", "2", "--size", "96", "--seed", "950001"), "--seed 950001 is not a training seed"),
    (("data", "generate", "--family", "blocks", "--count", "2", "--size", "96", "--seed", "900004"), "development evaluation sets use it"),
    (("reproduce", "transfer", "--eval-set", "sealed"), "'sealed' is sealed"),
    (("tune", "--method", "IQL", "--maps", "generated", "--eval-set", "sealed"), "'sealed' is sealed"),
    (("tune", "--method", "IQL", "--maps", "generated", "--eval-set", "select"), "tune on 'tune'"),
])
def test_the_cli_refuses_sealed_sets_and_evaluation_seeds_in_one_line(ndrql_exe, tmp_path, args, needle):
    r = run_cli(ndrql_exe, *args, "--out", tmp_path / "out", cwd=tmp_path)
    assert_one_line_error(r, needle)
    assert not (tmp_path / "out").exists()


def test_digests_are_of_content_and_tell_problems_apart():
    import numpy as np

    a = np.zeros((8, 8), bool)
    b = a.copy()
    b[3, 4] = True
    assert map_digest(a) == map_digest(a.copy()) != map_digest(b)
    assert problem_digest(map_digest(a), (0, 0), (7, 7)) != problem_digest(map_digest(a), (7, 7), (0, 0))


def test_a_changed_set_is_not_the_sealed_one(tmp_path):
    root = generate_set(tmp_path / "s", SetSpec(("blocks",), (96,), 3, 900_998), progress=False, purpose="evaluation")
    gs = GeneratedSet.load(root)
    with pytest.raises(NdrqlError, match="no recorded digests"):
        verify_seal("no-such-set", gs)
    rec = recorded_digests()["sets"]["sealed"]
    with pytest.raises(NdrqlError, match="does not match its recorded digests"):
        verify_seal("sealed", gs)
    assert len(rec["maps"]) == len(rec["problems"]) == 240


def test_every_registered_set_has_its_digests_recorded_and_no_map_or_problem_appears_twice():
    """Over every registered set and the training sets' recorded samples: not one map or problem twice,
    within a set or across sets (the digests are of content; tools/seal_sets.py records them)."""
    data = recorded_digests()
    sets = registry()
    assert set(data["sets"]) == set(sets), "run tools/seal_sets.py to record the new sets"
    for name, s in sets.items():
        assert data["sets"][name]["spec"] == s.spec.to_dict() and data["sets"][name]["role"] == s.role
        assert len(data["sets"][name]["maps"]) == s.spec.count
    records = [*data["sets"].values(), *data["training"].values()]
    assert data["training"] and all(len(r["maps"]) >= 240 for r in data["training"].values())
    for key in ("maps", "problems"):
        counts = Counter(d for r in records for d in r[key])
        twice = [d for d, c in counts.items() if c > 1]
        assert not twice, f"{len(twice)} {key} appear more than once: {twice[:5]}"


@pytest.mark.slow
def test_the_recorded_digests_are_what_the_generator_draws_today():
    """Regenerates a development set and the sealed set and hashes their maps (generation dominates)."""
    data = recorded_digests()
    for name in ("transfer-small", "sealed"):
        gs = eval_set(eval_spec(name, release=True), progress=False, release=True)
        assert set_record(gs) == {k: v for k, v in data["sets"][name].items() if k != "role"}
        verify_seal(name, gs)
    assert json.dumps(data)  # the file is plain JSON


def test_train_refuses_a_source_drawn_from_an_evaluation_seed_in_one_line(ndrql_exe, tmp_path):
    root = generate_set(tmp_path / "dev", SetSpec(("blocks",), (96,), 2, 900_997), progress=False, purpose="evaluation")
    r = run_cli(ndrql_exe, "train", "--sources", f"paper:1,{root}:3", "--run-dir", tmp_path / "run", cwd=tmp_path)
    assert_one_line_error(r, "an evaluation seed: it cannot be a training source")
    assert not (tmp_path / "run").exists()
