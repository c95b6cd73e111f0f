"""ndrql tune: search spaces, the objective on hand-made maps, the study (seeded, resumable), presets."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace

import numpy as np
import pytest

from ndrql.errors import NdrqlError
from ndrql.planning.config import PriorConfig, QLConfig
from ndrql.planning.methods import method_names
from ndrql.planning.preset import (PRESET_FIELDS, MethodSetting, Preset, PresetError, builtin_path, load_preset,
                                   method_configs, preset_from_dict, preset_to_dict, write_preset)
from ndrql.tuning import space as S
from ndrql.tuning.objective import Evaluation, chunks, evaluate, run_problem

from helpers import REPO_ROOT, TESTS_DIR
from helpers.cli import assert_one_line_error, run_cli
from helpers.tuning_problems import PROBLEMS, tune_config

optuna = pytest.importorskip("optuna")


# ------------------------------------------------------------------------------------------- spaces


def test_search_spaces_per_method():
    names = {m: [p.name for p in S.search_space(m)] for m in method_names()}
    base = ["alpha", "epsilon", "gamma"]
    assert names["QL"] == base and names["O-QL"] == base and names["D-Q"] == base  # D-QI has no constant
    assert names["D-C"] == base + ["r_max", "G"]
    assert names["N-C"] == base + ["r_max"]
    assert names["IQL"] == names["IQL-BFS"] == names["IQL-NDR"] == base + ["r_max", "G"]
    assert names["N-Q"] == base + ["omega_qi", "mask_low", "thd_start", "thd_step"]
    assert names["NDR-QL"] == base + ["r_max", "G", "omega_crf", "omega_qi", "mask_low", "thd_start", "thd_step"]


@pytest.mark.parametrize("method", method_names())
def test_spec_point_inside_every_space_and_round_trips(method):
    params = S.params_of(method, QLConfig(), PriorConfig())
    for p in S.search_space(method):
        assert p.low <= params[p.name] <= p.high
        assert set(p.fields) <= set(PRESET_FIELDS[p.part])
    ql, pc = S.configs_from_params(params)
    assert (ql, pc) == (QLConfig(), PriorConfig())


def test_g_sets_both_decay_lengths():
    ql, pc = S.configs_from_params({"G": 3.5, "alpha": 0.4})
    assert pc.g_row == pc.g_col == 3.5 and ql.alpha == 0.4 and ql.epsilon == QLConfig().epsilon


# ---------------------------------------------------------------------------------------- objective


def test_evaluation_known_answers():
    ev = Evaluation()
    ev.add("x", [(True, 100, 1.0), (True, 300, 1.2)])
    ev.add("y", [(False, 1000, math.nan)])
    assert ev.steps == pytest.approx(1400 / 3)  # pooled over runs, failed runs count their steps
    assert ev.ratio == pytest.approx(1.1)  # converged runs only
    assert ev.not_converged == 1 and ev.n_runs == 3
    assert [len(c) for c in chunks(list(range(7)), 3)] == [3, 3, 1]


def test_evaluate_matches_single_runs_and_ignores_chunking_and_workers():
    from ndrql.planning.runner import run_plan
    from ndrql.workers import process_pool

    seeds = [0, 1]
    ql, pc = QLConfig(max_episodes=3000), PriorConfig()
    one, stopped = evaluate(PROBLEMS, "NDR-QL", seeds, ql, pc)
    assert stopped == ""
    for p in PROBLEMS:
        for s, (conv, steps, ratio) in zip(seeds, one.runs[p.key]):
            r = run_plan(p.blocked, p.start, p.goal, "NDR-QL", s, ql, pc, region=p.region, guideline=p.guideline)
            assert conv == r.converged and steps == r.convergence_steps
            assert ratio == pytest.approx(r.path_length / p.astar) and ratio >= 1.0  # never shorter than A*
    chunked, _ = evaluate(PROBLEMS, "NDR-QL", seeds, ql, pc, chunk=1)
    with process_pool(2, start_method="fork") as pool:
        pooled, _ = evaluate(PROBLEMS, "NDR-QL", seeds, ql, pc, pool=pool, chunk=2)
    assert one.runs == chunked.runs == pooled.runs
    assert list(pooled.runs) == [p.key for p in PROBLEMS]


def test_evaluate_stops_at_the_first_run_that_does_not_converge():
    ql = QLConfig(max_episodes=3)  # nothing converges in 3 episodes (W = 20)
    ev, stopped = evaluate(PROBLEMS, "QL", [0, 1, 2], ql, PriorConfig(), stop_on_failure=True)
    assert stopped == "not converged" and list(ev.runs) == ["a-0"] and len(ev.runs["a-0"]) == 1
    assert run_problem(PROBLEMS[0], "QL", [0, 1], ql, PriorConfig()) == run_problem(PROBLEMS[0], "QL", [0, 1], ql,
                                                                                      PriorConfig())


def test_after_chunk_can_stop_an_evaluation():
    seen = []

    def after(i, ev):
        seen.append((i, len(ev.runs)))
        return i == 1

    ev, stopped = evaluate(PROBLEMS, "QL", [0], QLConfig(), PriorConfig(), chunk=1, after_chunk=after)
    assert stopped == "after_chunk" and seen == [(0, 1), (1, 2)] and len(ev.runs) == 2


# -------------------------------------------------------------------------------------------- study


def _trials(study):
    return [(t.number, t.state.name, t.value, dict(t.params)) for t in study.get_trials(deepcopy=False)]


def test_study_is_deterministic_per_seed_and_keeps_the_spec_point(tmp_path):
    from ndrql.tuning.study import best_trial, run_study

    runs = []
    for i, seed in enumerate((0, 0, 1)):
        st = run_study(tune_config(seed=seed), PROBLEMS, f"sqlite:///{tmp_path}/s{i}.db", progress=False)
        runs.append(st)
    a, b, c = (_trials(s) for s in runs)
    assert a == b  # same seed, one worker: the same trials, so the same best trial
    assert best_trial(runs[0]).number == best_trial(runs[1]).number
    assert [t[3] for t in a[1:]] != [t[3] for t in c[1:]]  # seed + 1: other constants
    t0 = runs[0].trials[0]
    assert t0.user_attrs["spec"] and t0.params == S.params_of("IQL", QLConfig(), PriorConfig())
    base = runs[0].user_attrs["baseline"]
    assert t0.value == base["steps"] and base["runs"] == 2 * len(PROBLEMS)
    bt = best_trial(runs[0])
    assert bt.value <= t0.value  # the SPEC point is feasible, so the best is never worse
    assert bt.user_attrs["c_ratio"] <= 0 and bt.user_attrs["c_not_converged"] <= 0
    assert runs[0].user_attrs["problems"] == [p.key for p in PROBLEMS]


def test_study_resumes_with_the_same_settings(tmp_path):
    from ndrql.tuning.study import finished, run_study

    url = f"sqlite:///{tmp_path}/s.db"
    first = _trials(run_study(tune_config(trials=3), PROBLEMS, url, progress=False))
    st = run_study(tune_config(trials=6), PROBLEMS, url, progress=False)
    assert finished(st) == 6 and _trials(st)[:3] == first  # continued: earlier trials kept as they were
    assert len(optuna.get_all_study_names(url)) == 1
    run_study(tune_config(trials=6, seed=0), PROBLEMS[:2], url, progress=False)  # other maps: another study
    assert len(optuna.get_all_study_names(url)) == 2


_KILL_SCRIPT = """
import sys
sys.path.insert(0, {tests!r})
from helpers.tuning_problems import PROBLEMS, tune_config
from ndrql.tuning.study import run_study
run_study(tune_config(trials=int(sys.argv[1]), heartbeat=1, grace=2), PROBLEMS, sys.argv[2], progress=False)
"""


@pytest.mark.slow
def test_killed_search_continues_the_same_study(tmp_path):
    """kill -9 in the middle of a search, run it again: the finished trials stay, the budget completes."""
    from ndrql.tuning.study import finished, run_study

    url = f"sqlite:///{tmp_path}/s.db"
    script = tmp_path / "run.py"
    script.write_text(_KILL_SCRIPT.format(tests=str(TESTS_DIR)))
    proc = subprocess.Popen([sys.executable, str(script), "500", url], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        done_before = 0
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                names = optuna.get_all_study_names(url)
                if names:
                    done_before = finished(optuna.load_study(study_name=names[0], storage=url))
            except Exception:
                pass
            if done_before >= 3:
                break
            time.sleep(0.05)
        assert proc.poll() is None, proc.stderr.read().decode()[-2000:]
        os.killpg(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
        proc.stderr.close()
    name = optuna.get_all_study_names(url)[0]
    before = _trials(optuna.load_study(study_name=name, storage=url))
    done_before = sum(1 for t in before if t[1] in ("COMPLETE", "PRUNED"))
    time.sleep(4)  # well past the 2 s grace period: a trial left running is failed and retried
    st = run_study(tune_config(trials=done_before + 2, heartbeat=1, grace=2), PROBLEMS, url, progress=False)
    assert st.study_name == name and optuna.get_all_study_names(url) == [name]
    after = _trials(st)
    assert finished(st) == done_before + 2
    kept = [t for t in before if t[1] in ("COMPLETE", "PRUNED")]
    assert [t for t in after if t[0] in {k[0] for k in kept}] == kept
    assert not any(t[1] == "RUNNING" for t in after)


def test_trial_killed_before_its_first_heartbeat_is_failed(tmp_path):
    """A trial created but never heart-beaten (kill -9 right after creation) is failed after the grace;
    a trial with a heartbeat, or a young one, is left to Optuna."""
    import warnings

    from ndrql.tuning.study import fail_orphans, open_storage

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        storage = open_storage(f"sqlite:///{tmp_path}/s.db", tune_config(heartbeat=1, grace=2))
        study = optuna.create_study(study_name="s", storage=storage)
        orphan, beating = study.ask(), study.ask()
        storage.record_heartbeat(beating._trial_id)
    assert fail_orphans(study, grace=2) == []  # too young
    time.sleep(2.5)
    assert fail_orphans(study, grace=2) == [orphan.number]
    states = {t.number: t.state.name for t in study.get_trials()}
    assert states == {orphan.number: "FAIL", beating.number: "RUNNING"}


def test_tune_config_rejects_bad_values():
    from ndrql.tuning.study import TuneConfig

    with pytest.raises(NdrqlError, match="unknown method"):
        TuneConfig("QQL")
    with pytest.raises(NdrqlError, match="trials must be an integer >= 1"):
        TuneConfig("QL", trials=0)
    assert TuneConfig("ndr-ql").method == "NDR-QL"


def test_paired_ratio_difference_known_answer():
    from ndrql.tuning.report import paired_ratio_difference

    a, b = Evaluation(), Evaluation()
    a.add("x", [(True, 10, 1.0), (True, 10, 1.2), (False, 99, math.nan)])
    b.add("x", [(True, 5, 1.1), (True, 5, 1.2), (True, 5, 1.0)])
    mean, se, n = paired_ratio_difference(a, b)
    assert n == 2 and mean == pytest.approx(0.05) and se == pytest.approx(np.std([0.1, 0.0], ddof=1) / math.sqrt(2))


def test_outputs_and_preset_from_a_study(tmp_path):
    from ndrql.tuning.report import best_setting, check_presets, tuned_preset, write_study_outputs
    from ndrql.tuning.study import best_trial, run_study

    st = run_study(tune_config(method="NDR-QL", trials=5), PROBLEMS, f"sqlite:///{tmp_path}/s.db", progress=False)
    folder = write_study_outputs(st, tune_config(method="NDR-QL", trials=5), tmp_path / "out")
    best = json.loads((folder / "best.json").read_text())
    assert best["best_trial"]["number"] == best_trial(st).number and (folder / "history.png").stat().st_size > 0
    assert len(json.loads((folder / "trials.json").read_text())) == 5
    setting, _ = best_setting(st, "NDR-QL")
    check = check_presets(PROBLEMS, ["NDR-QL"], {"NDR-QL": setting}, [5, 6])
    won = dict(check["NDR-QL"], tuned_wins=True)
    preset = tuned_preset({"NDR-QL": setting}, {"NDR-QL": won}, {"search": {"trials": 5}}, fallback="NDR-QL")
    assert preset.plan_default and preset.meta["kept_spec"] == []
    back = load_preset(write_preset(tmp_path / "p.json", preset))
    assert back.configs("NDR-QL") == (setting.ql, setting.priors)
    assert back.configs("D-C+N-C") == back.configs("NDR-QL")  # fallback for rows the search did not cover
    lost = tuned_preset({"NDR-QL": setting}, {"NDR-QL": dict(won, tuned_wins=False)}, {})
    assert lost.configs("D-C") == (QLConfig(), PriorConfig())  # not searched, no fallback: spec constants
    assert not lost.plan_default and lost.meta["kept_spec"] == ["NDR-QL"]
    assert lost.configs("NDR-QL") == (QLConfig(), PriorConfig())  # did not win on fresh seeds: spec constants


# ------------------------------------------------------------------------------------------ presets


def test_spec_preset_is_the_config_defaults():
    spec = load_preset("spec")
    for m in method_names():
        assert spec.configs(m) == (QLConfig(), PriorConfig())
    data = json.loads(builtin_path("spec").read_text())
    assert data["default"] == {"ql": {"alpha": 0.1, "epsilon": 0.2, "gamma": 0.95},
                               "priors": {"r_max": 5.0, "g_row": 10.0, "g_col": 10.0, "omega_crf": 0.5, "omega_qi": 0.5,
                                          "mask_low": -10.0, "thd_start": 0.99, "thd_step": 0.01}}
    assert load_preset(None).name == "spec"


def test_shipped_tuned_preset_is_valid_when_present():
    if not builtin_path("tuned").is_file():
        pytest.skip("no tuned preset shipped yet")
    tuned = load_preset("tuned")
    assert {"QL", "O-QL", "IQL", "NDR-QL"} <= set(tuned.methods)
    for m, s in tuned.methods.items():
        params = S.params_of(m, s.ql, s.priors)
        for p in S.search_space(m):
            assert p.low <= params[p.name] <= p.high
        assert s.ql.max_episodes == QLConfig().max_episodes  # the search's cap never leaks into a preset
    assert tuned.meta["search"]["problems"] and all(k.startswith("train-") for k in tuned.meta["search"]["problems"])


def test_preset_overrides_and_method_configs():
    p = Preset("x", methods={"QL": MethodSetting(QLConfig(alpha=0.5), PriorConfig()),
                             "NDR-QL": MethodSetting(QLConfig(gamma=0.9), PriorConfig(r_max=9.0))}, fallback="NDR-QL")
    assert p.configs("QL")[0].alpha == 0.5 and p.configs("ql")[0].alpha == 0.5
    assert p.configs("IQL")[1].r_max == 9.0  # not listed: the fallback entry
    q = p.with_overrides({"alpha": 0.2}, {"r_max": 3.0})
    assert q.configs("QL")[0].alpha == 0.2 and q.configs("NDR-QL") == (QLConfig(alpha=0.2, gamma=0.9),
                                                                        PriorConfig(r_max=3.0))
    assert method_configs(None, "QL", QLConfig(alpha=0.3)) == (QLConfig(alpha=0.3), PriorConfig())
    assert method_configs(p, "QL", QLConfig(epsilon=0.1)) == (QLConfig(alpha=0.5, epsilon=0.1), PriorConfig())
    assert preset_from_dict(preset_to_dict(p)).configs("NDR-QL") == p.configs("NDR-QL")
    assert p.only("NDR-QL").configs("QL") == p.configs("NDR-QL")  # Table 2's ablation: one set for every row


@pytest.mark.parametrize("data, message", [
    ([], "not an ndrql preset"),
    ({"format": "ndrql-preset", "version": 3}, "preset version 3"),
    ({"format": "ndrql-preset", "version": 2, "grids": {"big": {}}}, "'big' is not a grid size"),
    ({"format": "ndrql-preset", "version": 2, "grids": {"50": []}}, "grids.50 must be a mapping"),
    ({"format": "ndrql-preset", "version": 2, "grids": {"50": {"XQL": {}}}}, "unknown method 'XQL'"),
    ({"format": "ndrql-preset", "version": 2, "grids": {"50": {"QL": {"ql": {"alpha": 7.0}}}}}, "grids.50.QL.ql: alpha"),
    ({"format": "ndrql-preset", "version": 1, "methods": {"XQL": {}}}, "unknown method 'XQL'"),
    ({"format": "ndrql-preset", "version": 1, "methods": {"QL": {"ql": {"max_episodes": 5}}}}, "cannot be set by a preset"),
    ({"format": "ndrql-preset", "version": 1, "methods": {"QL": {"ql": {"alpha": "x"}}}}, "expected a finite number"),
    ({"format": "ndrql-preset", "version": 1, "methods": {"QL": {"ql": {"alpha": 7.0}}}}, "alpha must be in"),
    ({"format": "ndrql-preset", "version": 1, "fallback": "IQL"}, "fallback 'IQL' is not one of"),
])
def test_bad_presets_are_one_line_errors(data, message):
    with pytest.raises(PresetError, match=message) as exc:
        preset_from_dict(data, "p.json")
    assert "\n" not in str(exc.value)


def test_load_preset_errors(tmp_path):
    with pytest.raises(PresetError, match="unknown preset 'nope'"):
        load_preset("nope")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(PresetError, match="not valid JSON"):
        load_preset(bad)


def test_cli_preset_and_tune_errors(ndrql_exe, tmp_path):
    r = run_cli(ndrql_exe, "plan", "src/ndrql/data/sample_map.png", "--start", "25,179", "--goal", "167,5",
                "--preset", "nope", cwd=REPO_ROOT)
    assert r.returncode == 2 and r.stderr.strip() == ("ndrql: error: unknown preset 'nope': give spec, tuned, general, "
                                                      "belief or a preset JSON file")
    assert_one_line_error(run_cli(ndrql_exe, "tune"), "give --method NAME")
    assert_one_line_error(run_cli(ndrql_exe, "tune", "--method", "QQL"), "unknown method 'QQL'")
    assert_one_line_error(run_cli(ndrql_exe, "tune", "--method", "QL", "--trials", "0"), "--trials must be an integer")
    assert_one_line_error(run_cli(ndrql_exe, "tune", "--method", "QL", "--maps", "generated", "--grid", "1"),
                          "--grid must be an integer")  # the grid-size bounds every command shares: 2..1024
    assert_one_line_error(run_cli(ndrql_exe, "tune", "--export-preset", str(tmp_path / "g.json"), "--maps", "generated",
                                  "--grids", "50,x"), "--grids must be grid sizes")
    r = run_cli(ndrql_exe, "tune", "--help")
    assert r.returncode == 0 and "ndrql tune --method NDR-QL" in r.stdout


def test_per_grid_presets_take_the_nearest_size_on_a_log_scale(tmp_path):
    """Version 2: constants per planning-grid size; a grid takes the nearest entry (log scale), a
    method an entry lacks the next nearest entry's, then ``methods``, then ``default``."""
    from ndrql.planning.preset import load_preset, nearest_grid

    assert [nearest_grid([50, 100], n) for n in (20, 50, 70, 71, 100, 128, 400)] == [50, 50, 50, 100, 100, 100, 100]
    data = {"format": "ndrql-preset", "version": 2, "name": "g",
            "methods": {"QL": {"ql": {"alpha": 0.7}}},
            "grids": {"100": {"IQL": {"ql": {"alpha": 0.2}}, "NDR-QL": {"priors": {"r_max": 9.0}}},
                      "50": {"IQL": {"ql": {"alpha": 0.1}}}}}
    p = preset_from_dict(data, "g.json")
    assert p.configs("IQL", grid=50)[0].alpha == 0.1 and p.configs("IQL", grid=64)[0].alpha == 0.1
    assert p.configs("IQL", grid=80)[0].alpha == 0.2 and p.configs("IQL", grid=200)[0].alpha == 0.2
    assert p.configs("IQL")[0].alpha == 0.1  # grid unknown: the smallest size's entry
    assert p.configs("NDR-QL", grid=50)[1].r_max == 9.0  # not at 50: the next nearest size that has it
    assert p.configs("QL", grid=100)[0].alpha == 0.7  # in no grid entry: methods
    assert p.configs("O-QL", grid=100) == (QLConfig(), PriorConfig())  # nowhere: default
    assert method_configs(p, "IQL", QLConfig(epsilon=0.3), grid=100)[0] == QLConfig(alpha=0.2, epsilon=0.3)
    again = preset_from_dict(preset_to_dict(p), "again")
    assert again.grids == p.grids and preset_to_dict(p)["version"] == 2
    assert preset_to_dict(replace(p, grids={}))["version"] == 1  # a preset without grids stays readable by older ndrql
    assert p.only("IQL").configs("QL", grid=100)[0].alpha == 0.2  # the ablation: IQL's constants for every row, per grid
    assert p.with_overrides(ql={"gamma": 0.9}).configs("IQL", grid=100)[0] == QLConfig(alpha=0.2, gamma=0.9)
    write_preset(tmp_path / "g.json", p)
    assert load_preset(tmp_path / "g.json").configs("IQL", grid=128)[0].alpha == 0.2
    with pytest.raises(PresetError, match="unknown preset 'nope': give spec, tuned, general, belief or"):
        load_preset("nope")


def test_plan_default_preset_follows_the_weights():
    """``plan`` without ``--preset`` takes the constants searched for its weights when they won their check."""
    from ndrql.planning.preset import load_preset, plan_default_preset

    tuned, general = (builtin_path(n).is_file() and load_preset(n).plan_default for n in ("tuned", "general"))
    assert plan_default_preset("paper") == ("tuned" if tuned else "spec")
    for w in (None, "general", "my.pt"):
        assert plan_default_preset(w) == ("general" if general else "tuned" if tuned else "spec")
