"""One door for every error: the environment, argparse's type functions, third-party loggers, the API, the
terminal, shared folders and storages; each case one line naming what to change (in process, main())."""

from __future__ import annotations

import logging
import multiprocessing
import os
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ndrql.cli import main
from ndrql.errors import NdrqlError, OutputError

SAMPLE = ["--example"]


def one_line(capsys, argv: list[str], needle: str, code: int = 2) -> str:
    assert main(argv) == code
    err = capsys.readouterr().err
    assert err.startswith("ndrql: error: ") and err.count("\n") == 1 and needle in err, err
    return err


def test_a_bad_kernels_variable_is_one_line_naming_it(capsys, monkeypatch):
    monkeypatch.setenv("NDRQL_KERNELS", "bogus")
    one_line(capsys, ["plan", *SAMPLE, "--method", "IQL"], "NDRQL_KERNELS='bogus'")


def test_a_bad_number_in_the_environment_names_the_variable(monkeypatch):
    from ndrql.limits import env_number

    monkeypatch.setenv("NDRQL_EVAL_THREADS", "abc")
    with pytest.raises(NdrqlError, match="NDRQL_EVAL_THREADS"):
        env_number("NDRQL_EVAL_THREADS", 1)
    monkeypatch.setenv("NDRQL_EVAL_THREADS", "100000")
    with pytest.raises(NdrqlError, match="environment variable NDRQL_EVAL_THREADS must be an integer in 1.."):
        env_number("NDRQL_EVAL_THREADS", 1)


def test_argparse_type_functions_never_recurse_into_a_traceback(capsys):
    with pytest.raises(SystemExit) as exit_:  # argparse's own exit, after its one line
        main(["train", "--model-overrides", "[" * 50_000 + "]" * 50_000])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("ndrql: error: argument --model-overrides: nested too deeply") and err.count("\n") == 1


def test_an_error_before_the_command_runs_goes_through_the_door(capsys, monkeypatch):
    import ndrql.cli as cli

    def broken(command=None):
        raise RecursionError("deep")

    monkeypatch.setattr(cli, "build_parser", broken)
    one_line(capsys, ["plan"], "nested too deeply")


def test_optuna_prints_no_traceback_when_a_trial_is_interrupted(capfd, monkeypatch, tmp_path):
    pytest.importorskip("optuna")
    import ndrql.tuning.study as study_mod

    def interrupted(*_a, **_k):
        def objective(trial):
            trial.suggest_float("x", 0, 1)
            raise KeyboardInterrupt
        return objective

    monkeypatch.setattr(study_mod, "make_objective", interrupted)
    monkeypatch.setattr(study_mod, "baseline", lambda *a, **k: {"ratio": 1.0})
    monkeypatch.setattr(study_mod.compiled, "warm_up", lambda: None)
    cfg = study_mod.TuneConfig(method="IQL", trials=1)
    problem = type("P", (), {"key": "k"})()
    with pytest.raises(KeyboardInterrupt):
        study_mod.run_study(cfg, [problem], f"sqlite:///{tmp_path / 's.db'}", progress=False, name="ctrl-c")
    err = capfd.readouterr().err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert logging.getLogger("optuna").getEffectiveLevel() >= logging.ERROR


def test_the_door_turns_ctrl_c_into_one_line(capsys, monkeypatch):
    import ndrql.cli.astar_cmd as astar_cmd

    def interrupt(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(astar_cmd, "run", interrupt)
    assert main(["astar", *SAMPLE]) == 130
    assert capsys.readouterr().err.endswith("ndrql: interrupted\n")


@pytest.mark.parametrize("fields", [{"config": {}}, {"preset": {}}, {"weights": 5}, {"robot_radius": "x"},
                                    {"tolerance": {}}, {"max_size": [None]}, {"fallback": {}}, {"seeds": "x"},
                                    {"methods": 5}, {"methods": [{}]}, {"max_map_pixels": "many"}, {"scen": 5},
                                    {"crop": []}, {"workers": "x"}, {"workers": 10**6}, {"nonsense": 1}])
def test_the_api_raises_ndrql_errors_only(fields):
    import ndrql
    from ndrql.errors import ArgumentError
    from ndrql.maps.bundled import bundled_sample

    sample = bundled_sample()
    with pytest.raises(NdrqlError) as raised:
        ndrql.solve(sample.grid_map, sample.start, sample.goal, **fields)
    assert "nonsense" not in fields or isinstance(raised.value, (ArgumentError, TypeError))


def test_a_settings_object_refuses_what_is_not_a_number():
    from ndrql.pipeline.settings import PlanSettings

    for bad in ({"robot_radius": "x"}, {"tolerance": {}}, {"max_size": [None]}, {"fallback": {}}, {"backend": 5}):
        with pytest.raises(NdrqlError):
            PlanSettings(**bad)


def test_control_characters_in_a_maps_name_are_escaped_once_on_stdout(capsys, tmp_path):
    name = tmp_path / "e\x1b]0;pwn\x07\r.png"
    Image.fromarray(np.full((8, 8), 255, np.uint8)).save(name)
    assert main(["map", "info", str(name)]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\x07" not in out and "\r" not in out
    assert "e\\x1b]0;pwn\\x07\\x0d.png" in out and "\\\\x1b" not in out


def test_average_weights_refuses_a_share_that_is_not_finite(capsys, tmp_path):
    pytest.importorskip("torch")
    from ndrql.model.weights import shipped_weights

    w = str(shipped_weights("paper"))
    for shares in ("inf,1", "nan,1", "1e300,1"):
        one_line(capsys, ["average-weights", w, w, "--shares", shares, "--out", str(tmp_path / "avg.pt")], "share")
    assert not (tmp_path / "avg.pt").exists()


def test_one_run_folder_is_held_by_one_training_at_a_time(tmp_path):
    from ndrql.io import folder_lock

    with folder_lock(tmp_path / "run", "run folder"):
        with pytest.raises(OutputError, match=r"in use by another ndrql run"):
            with folder_lock(tmp_path / "run", "run folder"):
                pass
    with folder_lock(tmp_path / "run", "run folder"):  # released: the next run may go
        pass
    assert list((tmp_path / "run").iterdir()) == []  # no lock file left in the run folder


def test_ros_yaml_numbers_are_read_as_map_server_reads_them(tmp_path):
    from ndrql.maps.readers import load_map

    Image.fromarray(np.full((8, 8), 255, np.uint8)).save(tmp_path / "m.png")
    (tmp_path / "m.yaml").write_text("image: m.png\nresolution: 010\norigin: [0, 0, 0]\noccupied_thresh: 0.65\n"
                                     "free_thresh: 0.196\nnegate: 0\n")
    assert load_map(tmp_path / "m.yaml").resolution == 10


@pytest.mark.parametrize("make", ["folder", "map", "link"])
def test_tune_refuses_a_storage_it_cannot_use_before_any_trial(capsys, tmp_path, make):
    target = tmp_path / "store"
    if make == "folder":
        target.mkdir()
    elif make == "map":
        target.write_bytes(b"\x89PNG not a database")
    else:
        target.symlink_to(tmp_path / "elsewhere.db")
    before = target.read_bytes() if make == "map" else None
    one_line(capsys, ["tune", "--method", "IQL", "--storage", f"sqlite:///{target}", "--out", str(tmp_path / "o")],
             "--storage")
    assert not (tmp_path / "o").exists() and (before is None or target.read_bytes() == before)


def _share(url: str, i: int, queue) -> None:
    import warnings

    import optuna

    from ndrql.tuning.study import TuneConfig, open_storage, open_study

    warnings.simplefilter("ignore")  # Optuna's note that heartbeats are meant for optimize(), not ask/tell
    optuna.logging.set_verbosity(optuna.logging.ERROR)
    try:
        cfg = TuneConfig(method="IQL")
        study = open_study(cfg, "shared", open_storage(url, cfg))
        for _ in range(3):
            trial = study.ask()
            study.tell(trial, float(i))
        queue.put("ok")
    except Exception as exc:  # noqa: BLE001 - reported to the parent
        queue.put(f"{type(exc).__name__}: {exc}")


def test_several_tune_processes_share_one_new_sqlite_storage(tmp_path):
    pytest.importorskip("optuna")
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    url = f"sqlite:///{tmp_path / 'shared.db'}"
    procs = [ctx.Process(target=_share, args=(url, i, queue)) for i in range(3)]
    for p in procs:
        p.start()
    got = [queue.get(timeout=300) for _ in procs]
    for p in procs:
        p.join()
    assert got == ["ok"] * 3
    import optuna

    assert len(optuna.load_study(study_name="shared", storage=url).trials) == 9
    assert os.path.getsize(Path(url[len("sqlite:///"):])) > 0


def test_a_ros_resolution_beyond_any_map_is_refused(tmp_path):
    from ndrql.errors import MapFormatError
    from ndrql.maps.readers import load_map

    Image.fromarray(np.full((8, 8), 255, np.uint8)).save(tmp_path / "m.png")
    for value in ("1e-300", "1e300"):
        (tmp_path / "m.yaml").write_text(f"image: m.png\nresolution: {value}\norigin: [0, 0, 0]\n"
                                         "occupied_thresh: 0.65\nfree_thresh: 0.196\nnegate: 0\n")
        with pytest.raises(MapFormatError, match="resolution"):
            load_map(tmp_path / "m.yaml")


def test_a_missing_scenario_file_is_called_a_scenario(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a.map").write_text("type octile\nheight 4\nwidth 4\nmap\n" + "....\n" * 4)
    one_line(capsys, ["plan", "a.map", "--scen", "nope.scen:1", "--method", "IQL"], "MovingAI scenario file not found")


def test_a_second_training_on_a_run_folder_in_use_is_refused_before_any_work(tmp_path):
    pytest.importorskip("torch")
    from ndrql.io import folder_lock
    from ndrql.training.config import TrainConfig
    from ndrql.training.loop import run_training

    with folder_lock(tmp_path / "run", "run folder"):  # the first training, still running
        with pytest.raises(OutputError, match="run folder .* is in use by another ndrql run"):
            run_training(TrainConfig(), tmp_path / "run", progress=False, log=lambda *_: None)
    assert list((tmp_path / "run").iterdir()) == []
