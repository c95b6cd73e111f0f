"""Generated sets on disk, rendering for the two input modes, mixtures, and a mixed multi-scale run that resumes."""

from __future__ import annotations


import numpy as np
import pytest
import torch

from ndrql.dataset.generated import GeneratedSet, generate_set, shard_path
from ndrql.dataset.mixture import Mixture, batch_size_for, generated_source, parse_families, parse_sources, SourceSpec
from ndrql.dataset.render import grid_input, input_side, render
from ndrql.errors import NdrqlError
from ndrql.maps.safe import conservative_grid, point_to_square_cell
from ndrql.synth.generate import SetSpec, generate_sample
from ndrql.synth.oracle import oracle_prediction

from helpers.cli import assert_one_line_error, run_cli

SPEC = SetSpec(("maze", "blocks"), (96, 128), 10, 3)


@pytest.fixture(scope="module")
def gen_set(tmp_path_factory):
    root = tmp_path_factory.mktemp("gen") / "set"
    generate_set(root, SPEC, workers=1, progress=False, shard_size=4)
    return root


def test_set_is_deterministic_resumable_and_matches_the_generator(gen_set, tmp_path):
    other = tmp_path / "other"
    generate_set(other, SPEC, workers=2, progress=False, shard_size=4)  # other process count, same bytes
    for k in range(3):
        assert shard_path(gen_set, k).read_bytes() == shard_path(other, k).read_bytes()
    before = shard_path(other, 1).read_bytes()
    shard_path(other, 1).unlink()  # an interrupted run: resume writes exactly the missing shard
    generate_set(other, SPEC, workers=1, progress=False, shard_size=4)
    assert shard_path(other, 1).read_bytes() == before
    gs = GeneratedSet.load(gen_set)
    assert len(gs) == 10 and list(gs.families[:4]) == ["maze", "blocks", "maze", "blocks"]
    for i in (0, 5, 9):
        raw, ref = gs.raw(i), generate_sample(SPEC, i)
        assert np.array_equal(raw.obstacles, ref.obstacles) and raw.start == ref.start and raw.goal == ref.goal
        assert np.array_equal(raw.waypoints, ref.waypoints)
        assert tuple(raw.waypoints[0]) == raw.start and tuple(raw.waypoints[-1]) == raw.goal
        assert not raw.obstacles[raw.start] and not raw.obstacles[raw.goal]
    assert not np.array_equal(generate_sample(SPEC, 0).obstacles, generate_sample(SetSpec(SPEC.families, SPEC.sizes, 10, 4), 0).obstacles)


def test_another_spec_in_the_same_directory_is_refused(gen_set):
    with pytest.raises(NdrqlError, match="another set"):
        generate_set(gen_set, SetSpec(("maze",), (96,), 10, 3), progress=False, shard_size=4)


def test_incomplete_set_says_how_to_finish(gen_set, tmp_path):
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(gen_set, copy)
    shard_path(copy, 2).unlink()
    with pytest.raises(NdrqlError, match="incomplete"):
        GeneratedSet.load(copy)


def test_grid_mode_renders_the_grid_and_the_oracle(gen_set):
    raw = GeneratedSet.load(gen_set).raw(1)
    n = 24
    r = render("grid", raw.obstacles, raw.start, raw.goal, raw.waypoints, n)
    assert r is not None and r.obstacles.shape == (input_side("grid", n),) * 2 == (96, 96)
    blocked = conservative_grid(raw.obstacles, n)
    s, g = point_to_square_cell(raw.start, raw.obstacles.shape, n), point_to_square_cell(raw.goal, raw.obstacles.shape, n)
    img, sp, gp = grid_input(blocked, s, g, n)
    assert np.array_equal(r.obstacles, img) and r.start == sp and r.goal == gp
    assert np.array_equal(r.obstacles[::4, ::4][:blocked.shape[0], :blocked.shape[1]], blocked)
    region, guide = oracle_prediction(blocked, s, g, 4)
    assert np.array_equal(r.guideline[:guide.shape[0], :guide.shape[1]], guide > 0.5)
    assert np.array_equal(r.region[:region.shape[0], :region.shape[1]], region > 0.5)
    assert not r.obstacles[r.start] and not r.obstacles[r.goal]


def test_map_mode_scales_map_and_path(gen_set):
    raw = GeneratedSet.load(gen_set).raw(0)
    for n in (24, 50):
        r = render("map", raw.obstacles, raw.start, raw.goal, raw.waypoints, n)
        assert r.obstacles.shape == (4 * n + 1,) * 2
        assert r.guideline.sum() > 0 and (r.region >= r.guideline).all()
        # the guideline runs from start to goal at the new scale
        ys, xs = np.nonzero(r.guideline)
        d_start = np.min(np.hypot(ys - r.start[0], xs - r.start[1]))
        d_goal = np.min(np.hypot(ys - r.goal[0], xs - r.goal[1]))
        assert d_start <= 2 and d_goal <= 2


def test_disconnected_on_the_grid_renders_to_none():
    obstacles = np.zeros((64, 64), bool)
    obstacles[:, 31] = True  # a one-pixel wall: the conservative grid keeps it, so the halves never meet
    assert render("grid", obstacles, (5, 5), (60, 60), None, 16) is None


def test_sources_and_batches_are_deterministic(gen_set):
    assert parse_sources("paper:1,/x/y:3") == [SourceSpec("paper", 1.0), SourceSpec("/x/y", 3.0)]
    with pytest.raises(NdrqlError):
        parse_sources("paper:-1")
    mix = Mixture([generated_source(SourceSpec(str(gen_set), 1.0), val_fraction=0.5)], "grid", (16, 24))
    a = mix.batch(seed=0, epoch=0, step=3, batch_size=8)
    b = mix.batch(seed=0, epoch=0, step=3, batch_size=8)
    for x, y in zip(a, b):
        assert torch.equal(x, y)
    side = a[0].shape[-1]
    assert side in (64, 96) and a[0].shape[0] == batch_size_for(side, 8)
    sides = {mix.batch(0, 0, s, 8)[0].shape[-1] for s in range(12)}
    assert sides == {64, 96}  # both scales are drawn
    val = mix.validation(4)
    assert 1 <= len(val) <= 4 and all(name == "set" for name, _ in val)


def test_excluded_families_leave_both_parts(gen_set):
    gs = GeneratedSet.load(gen_set)
    full = generated_source(SourceSpec(str(gen_set), 1.0), val_fraction=0.5)
    kept = generated_source(SourceSpec(str(gen_set), 1.0), val_fraction=0.5, exclude=frozenset({"maze"}))
    everything = np.concatenate([full.train_ids, full.val_ids])
    expected = everything[gs.families[everything] != "maze"]
    assert np.array_equal(np.concatenate([kept.train_ids, kept.val_ids]), expected)
    assert set(gs.families[expected]) == {"blocks"} and "maze" in set(gs.families)
    assert np.isin(kept.val_ids, full.val_ids).all()  # the validation part stays the set's tail
    with pytest.raises(NdrqlError, match="no samples left"):
        generated_source(SourceSpec(str(gen_set), 1.0), exclude=frozenset({"maze", "blocks"}))
    assert parse_families(" maze, office ") == {"maze", "office"} and parse_families("") == frozenset()
    with pytest.raises(NdrqlError, match="unknown family mazes"):
        parse_families("mazes")


def test_mixed_multiscale_training_resumes_exactly(gen_set, tmp_path):
    from ndrql.model.checkpoint import load_checkpoint
    from ndrql.training.config import TrainConfig
    from ndrql.training.loop import train

    def cfg(**kw):
        base = dict(sources=f"{gen_set}:1", input_mode="grid", grid_sizes="16,24", model_overrides={"width": 0.25},
                    batch_size=4, epochs=2, steps_per_epoch=3, warmup_steps=2, bf16=False, threads=1, val_per_source=2)
        return TrainConfig(**{**base, **kw})

    quiet = dict(progress=False, log=lambda m: None)
    train(cfg(), tmp_path / "straight", **quiet)
    state = train(cfg(max_steps=4), tmp_path / "split", **quiet)
    assert state["global_step"] == 4
    train(cfg(), tmp_path / "split", resume=True, **quiet)
    a, b = load_checkpoint(tmp_path / "straight" / "last.pt"), load_checkpoint(tmp_path / "split" / "last.pt")
    assert a["state"]["global_step"] == b["state"]["global_step"] == 6
    assert a["config"]["input_mode"] == "grid"
    for k in a["model"]:
        assert torch.allclose(a["model"][k].float(), b["model"][k].float(), atol=1e-5), k
    # warm start from a checkpoint of the same architecture
    logs: list[str] = []
    train(cfg(init_weights=str(tmp_path / "straight" / "last.pt"), epochs=1, max_steps=1), tmp_path / "warm",
          progress=False, log=logs.append)
    assert any("warm start" in m for m in logs)
    # a warm start scores its starting weights first, on the same validation inputs as its epochs
    logs.clear()
    train(cfg(init_weights=str(tmp_path / "straight" / "last.pt"), epochs=1), tmp_path / "warm-full",
          progress=False, log=logs.append)
    import csv

    from ndrql.model.checkpoint import model_from_checkpoint
    from ndrql.training.evaluate import evaluate_rendered
    from ndrql.training.loop import build_mixture

    with (tmp_path / "warm-full" / "metrics.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [r["epoch"] for r in rows] == ["0", "1"] and rows[0]["global_step"] == "0"
    items = build_mixture(cfg(), progress=False)[0].validation(2)
    start = evaluate_rendered(model_from_checkpoint(load_checkpoint(tmp_path / "straight" / "last.pt")), items)
    assert rows[0]["val_region_f1"] == str(round(start["region_f1"], 3))  # the same inputs, the same number (nan too)
    assert any(m.startswith("starting weights: val region F1") for m in logs)
    assert "start_f1" in load_checkpoint(tmp_path / "warm-full" / "last.pt")["state"]
    from ndrql.errors import CheckpointError

    with pytest.raises(CheckpointError, match="init-weights"):
        train(cfg(init_weights=str(tmp_path / "straight" / "last.pt"), model_overrides={"width": 0.5}, max_steps=1),
              tmp_path / "warm2", **quiet)


def test_a_run_under_a_view_draws_merged_grids_and_records_the_view(gen_set, tmp_path):
    from ndrql.dataset.views import GridView
    from ndrql.model.checkpoint import load_checkpoint
    from ndrql.training.config import TrainConfig
    from ndrql.training.loop import build_mixture, train

    cfg = TrainConfig(sources=f"{gen_set}:1", input_mode="grid", grid_sizes="32", view="coarse:16",
                      model_overrides={"width": 0.25}, batch_size=2, epochs=1, steps_per_epoch=1, warmup_steps=1,
                      bf16=False, threads=1, val_per_source=1)
    mixture = build_mixture(cfg, progress=False)[0]
    assert mixture.view == GridView("coarse", 16)
    x = mixture.batch(0, 0, 0, 2)[0]
    assert x.shape[-1] == 64  # 32 cells merged 2 x 2 into 16, drawn at 4 px per merged cell
    train(cfg, tmp_path / "run", progress=False, log=lambda m: None)
    assert load_checkpoint(tmp_path / "run" / "last.pt")["config"]["view"] == "coarse:16"
    with pytest.raises(ValueError, match="--view needs --input-mode grid"):
        TrainConfig(view="coarse:16")


def test_grids_above_256_cells_train_only_under_a_view_that_bounds_the_input(gen_set):
    """The size ladder plan climbs reaches 512 cells; a capped view draws them at 1 px per cell (a native one
    would be a 2,048 px input), so only such a run may ask for them."""
    from ndrql.dataset.mixture import MAX_VIEW_SIZE, parse_sizes
    from ndrql.training.config import TrainConfig
    from ndrql.training.loop import build_mixture

    assert parse_sizes("256,512", MAX_VIEW_SIZE) == (256, 512)
    with pytest.raises(NdrqlError, match=r"grid sizes must be 8\.\.256, got '512'"):
        parse_sizes("512")
    with pytest.raises(NdrqlError, match=r"grid sizes must be 8\.\.512"):
        parse_sizes("600", MAX_VIEW_SIZE)
    base = dict(sources=f"{gen_set}:1", input_mode="grid", grid_sizes="160", model_overrides={"width": 0.25},
                batch_size=2, bf16=False, threads=1, val_per_source=1)
    mixture = build_mixture(TrainConfig(**base, view="cap:64"), progress=False)[0]
    assert mixture.sizes == (160,) and mixture.batch(0, 0, 0, 2)[0].shape[-1] == 160  # 1 px per cell
    with pytest.raises(NdrqlError, match=r"8\.\.256"):
        build_mixture(TrainConfig(**{**base, "grid_sizes": "320"}), progress=False)
    with pytest.raises(NdrqlError, match="view must be"):
        TrainConfig(input_mode="grid", view="tiles")


def test_data_cli_generate_and_show(tmp_path, ndrql_exe):
    out = tmp_path / "s"
    res = run_cli(ndrql_exe, "data", "generate", "--family", "maze,rooms", "--count", "3", "--size", "96",
                  "--seed", "5", "--out", str(out), "--no-progress")
    assert res.returncode == 0, res.stderr
    assert "wrote 3 samples" in res.stdout
    res = run_cli(ndrql_exe, "data", "show", str(out), "--png", str(tmp_path / "sheet.png"), "--count", "3",
                  "--mode", "grid", "--grid", "24")
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "sheet.png").stat().st_size > 2000
    res = run_cli(ndrql_exe, "data", "generate", "--family", "nope", "--count", "3", "--out", str(tmp_path / "x"))
    assert_one_line_error(res, "valid:")
