"""The goal-distance head: its output, its labels, its loss, its training beside a fixed trunk."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from ndrql.dataset.render import DISTANCE_UNIT, goal_distance_pixels, render_grid
from ndrql.model.checkpoint import save_checkpoint
from ndrql.model.registry import build_model
from ndrql.training.evaluate import order_accuracy
from ndrql.planning.priors import snap_detour
from ndrql.training.losses import ORDER_SCALE, distance_loss, greedy_move_loss, ndr_loss, soft_snap

TINY = {"arch": "ndr", "encoding": "point", "backbone": "stdc1", "width": 0.25, "unet_base": 8, "input_mode": "grid"}


@pytest.fixture(autouse=True)
def _seed():
    torch.manual_seed(0)


@pytest.mark.parametrize("decoder", ["coarse", "skips"])
@pytest.mark.parametrize("size", [(64, 64), (40, 72)])
def test_third_output_at_input_size_only_with_the_head(size, decoder):
    with_head = build_model({**TINY, "distance_head": True, "distance_decoder": decoder}).eval()
    out = with_head(torch.zeros(2, 3, *size))
    assert len(out) == 3 and all(t.shape == (2, 1, *size) for t in out)
    assert out[2].dtype == torch.float32
    assert len(build_model(TINY).eval()(torch.zeros(1, 3, *size))) == 2


def test_skips_head_sees_a_wall_the_coarse_field_cannot():
    """A one-pixel change of the walls changes the skips head's output next to it (the path through the
    strides 2 and 4), with the coarse layers unchanged."""
    model = build_model({**TINY, "distance_head": True, "distance_decoder": "skips"}).eval()
    x = torch.zeros(1, 3, 64, 64)
    x[0, 2, 32, 60] = 1.0
    moved = x.clone()
    moved[0, 0, 10, 10] = 1.0
    with torch.no_grad():
        a, b = model(x)[2], model(moved)[2]
    near = (a - b)[0, 0, 6:15, 6:15].abs().max()
    assert float(near) > 0


def test_unknown_distance_decoder_is_one_line():
    from ndrql.model.registry import check_config

    with pytest.raises(ValueError, match="unknown distance_decoder 'unet'.*valid: coarse, skips"):
        check_config({**TINY, "distance_head": True, "distance_decoder": "unet"})


def test_warm_start_of_the_skips_head_from_a_coarse_one_keeps_its_coarse_layers(tmp_path):
    from ndrql.training.start import warm_start

    coarse_cfg = {**TINY, "distance_head": True}
    coarse = build_model(coarse_cfg)
    src = save_checkpoint(tmp_path / "coarse.pt", {"config": coarse_cfg, "model": coarse.state_dict()})
    cfg = {**coarse_cfg, "distance_decoder": "skips"}
    model = build_model(cfg)
    fresh = {k: v.clone() for k, v in model.state_dict().items()}
    warm_start(model, str(src), cfg)
    state, old = model.state_dict(), coarse.state_dict()
    assert all(torch.equal(state[k], old[k]) for k in old if not k.startswith("distance.refine."))
    assert any(k.startswith("distance.coarse.") for k in old)
    assert not any(k.startswith("distance.refine.") for k in state)  # the coarse head's own refinement is dropped
    new = [k for k in state if k.startswith(("distance.enc", "distance.up", "distance.out"))]
    assert new and all(torch.equal(state[k], fresh[k]) for k in new)


def test_distance_output_is_fp32_under_bf16_autocast():
    model = build_model({**TINY, "distance_head": True, "distance_decoder": "skips"}).eval()
    with torch.inference_mode(), torch.autocast("cpu", dtype=torch.bfloat16):
        region, _, dist = model(torch.zeros(1, 3, 64, 64))
    assert region.dtype == torch.bfloat16 and dist.dtype == torch.float32


def test_goal_distance_label_is_the_hand_counted_bfs():
    blocked = np.zeros((3, 4), bool)
    blocked[1, 1:3] = True  # a wall in the middle row
    d = goal_distance_pixels(blocked, (0, 0), 16)
    cells = d[:12:4, :16:4]  # one pixel per cell
    expect = np.array([[0, 1, 2, 3], [1, -1, -1, 4], [2, 3, 4, 5]], np.float32)
    assert np.array_equal(cells, expect)
    assert np.array_equal(d[:12, :16], np.kron(expect, np.ones((4, 4), np.float32)))  # 4 px per cell
    assert (d[12:] == -1).all()  # padding below the grid is unknown


def test_render_grid_carries_the_distance_of_its_goal_cell():
    obstacles = np.zeros((64, 64), bool)
    obstacles[20:44, 30:34] = True
    r = render_grid(obstacles, (32, 5), (32, 60), 16)
    assert r is not None and r.distance is not None and r.distance.shape == r.obstacles.shape
    g = r.goal
    assert r.distance[g] == 0 and r.distance.max() > 0
    assert (r.distance[r.obstacles] == -1).all()  # blocked pixels are unknown


def test_distance_loss_ranks_neighbours_and_ignores_unknown_pixels():
    # a row of 4 cells (4 px each) leading to the goal on the left: distances 0..3 moves, no walls
    manh = np.repeat(np.arange(4, dtype=np.float32), 4)[None, :].repeat(4, 0) / DISTANCE_UNIT
    target = torch.from_numpy(np.stack([np.zeros_like(manh), manh]))[None]  # detour 0 everywhere
    right = torch.zeros(1, 1, 4, 16)
    worse = right.clone()
    worse[..., 8:] = -3.0 / DISTANCE_UNIT  # cells 2 and 3 now look nearer than cell 1: one pair out of order
    l_right, l_worse = float(distance_loss(right, target)), float(distance_loss(worse, target))
    assert l_worse > l_right > 0  # the ranking term never reaches 0 (logistic), but ordered is lower
    flat = worse.clone()
    flat[..., 8:] = -1.0 / DISTANCE_UNIT  # a tie where the true distances differ: between the two
    assert l_right < float(distance_loss(flat, target)) < l_worse
    unknown = target.clone()
    unknown[:, 0] = -1.0
    assert float(distance_loss(worse, unknown)) == 0.0  # nothing known: no loss
    # the Manhattan part cancels: a detour that exactly matches a shifted target ranks the same
    assert float(distance_loss(right + 0.5, target + torch.tensor([0.5, 0.0])[None, :, None, None])) == pytest.approx(
        l_right, rel=1e-5)


def test_soft_snap_is_the_snap_at_integers_and_flat_where_the_snap_keeps_a_value():
    q = torch.arange(-2.0, 9.0, 1.0, requires_grad=True)
    assert torch.allclose(soft_snap(q), q.detach().clamp(min=0), atol=1e-6)  # exact at every integer
    soft_snap(q).sum().backward()
    slope, v = q.grad.numpy(), q.detach().numpy()
    assert np.allclose(slope[(v >= 0) & (v % 2 == 0)], 0.0, atol=1e-6)  # flat at evens
    assert np.allclose(slope[(v > 0) & (v % 2 == 1)], 4.0, atol=1e-5)  # steepest at odds, where the snap jumps
    assert np.allclose(slope[v < 0], 0.0)  # a negative detour snaps to 0
    # the hard snap it stands in for: halfway between steps, soft_snap lies between them
    assert snap_detour(np.array([0.9, 1.1, 2.9, 3.1])).tolist() == [0.0, 2.0, 2.0, 4.0]


def test_snapped_ranking_punishes_a_pair_that_only_the_snap_puts_out_of_order():
    # cells 0..3 on a row, goal on the left, no walls: true detour 0 everywhere. The prediction puts a
    # detour of 1.4 moves on cell 1 and 0.6 on cell 2: raw, the distances 0, 2.4, 2.6, 3 still rise, but
    # Eq. 6 snaps the detours to 2 and 0 moves: 0, 3, 2, 3, and cell 1 looks farther than cell 2.
    manh = np.repeat(np.arange(4, dtype=np.float32), 4)[None, :].repeat(4, 0) / DISTANCE_UNIT
    target = torch.from_numpy(np.stack([np.zeros_like(manh), manh]))[None]
    pred = torch.zeros(1, 1, 4, 16)
    pred[..., 4:8], pred[..., 8:12] = 1.4 / DISTANCE_UNIT, 0.6 / DISTANCE_UNIT
    raw_total = pred[0, 0, 0, ::4] * DISTANCE_UNIT + torch.arange(4.0)
    assert bool((raw_total.diff() > 0).all())  # raw: ordered right
    snapped_total = torch.from_numpy(snap_detour(pred[0, 0, 0, ::4].numpy() * DISTANCE_UNIT)) + torch.arange(4.0)
    assert not bool((snapped_total.diff() > 0).all())  # snapped: cells 1 and 2 out of order
    clean = torch.zeros_like(pred)
    gap = float(distance_loss(pred, target, rank_on="raw+snapped")) - float(distance_loss(clean, target, rank_on="raw+snapped"))
    raw_gap = float(distance_loss(pred, target)) - float(distance_loss(clean, target))
    assert gap > raw_gap > 0  # the snapped term sees the swap the raw term barely feels
    with pytest.raises(ValueError, match="rank_on must be one of raw, raw\\+snapped"):
        distance_loss(pred, target, rank_on="snapped")


def test_greedy_move_loss_equals_the_softmax_over_neighbours_computed_by_hand():
    # a 3 x 3 open grid, one pixel per cell, goal at the top left: the true distance is the Manhattan one
    truth = torch.tensor([[0.0, 1, 2], [1, 2, 3], [2, 3, 4]])[None, None]
    known, weight = torch.ones_like(truth, dtype=torch.bool), torch.ones_like(truth)
    pred = truth.clone()
    pred[0, 0, 0, 1] = pred[0, 0, 1, 0] = 9.0  # both truly nearer neighbours of the centre look far
    # by hand: every cell with a truly nearer and a truly farther known neighbour counts (the goal has
    # no nearer one, the far corner no farther one): -log of the softmax(-ORDER_SCALE * d) mass on the nearer
    def nll(nearer: list[float], other: list[float]) -> float:
        z = [math.exp(-ORDER_SCALE * v) for v in nearer + other]
        return -math.log(sum(z[:len(nearer)]) / sum(z))
    cells = [nll([0], [2, 2]), nll([0], [2, 2]),  # (0,1) and (1,0): the goal vs (0,2)/(1,1), (2,0)/(1,1)
             nll([9], [3]), nll([9], [3]),  # (0,2) and (2,0): the far-looking nearer cell vs (1,2) / (2,1)
             nll([9, 9], [3, 3]),  # the centre: both nearer neighbours look far
             nll([2, 2], [4]), nll([2, 2], [4])]  # (1,2) and (2,1); the goal and (2,2) do not count
    assert float(greedy_move_loss(pred, truth, known, weight, 1)) == pytest.approx(sum(cells) / len(cells), rel=1e-5)
    assert float(greedy_move_loss(truth, truth, known, weight, 1)) < 0.05  # the truth itself: near 0
    blocked = known.clone()
    blocked[0, 0, 0, 1] = False  # a blocked neighbour takes no part in the softmax
    assert float(greedy_move_loss(pred, truth, blocked, weight, 1)) != float(greedy_move_loss(pred, truth, known, weight, 1))
    assert float(greedy_move_loss(pred, truth, torch.zeros_like(known), weight, 1)) == 0.0


def test_moves_term_is_added_only_with_its_option_and_weighs_the_route():
    manh = np.repeat(np.arange(4, dtype=np.float32), 4)[None, :].repeat(4, 0) / DISTANCE_UNIT
    target = torch.from_numpy(np.stack([np.zeros_like(manh), manh]))[None]
    pred = torch.zeros(1, 1, 4, 16)
    pred[..., 4:8] = 3.0 / DISTANCE_UNIT  # cell 1 looks farther than cell 2: cell 2's greedy move goes wrong
    snapped = float(distance_loss(pred, target, rank_on="raw+snapped"))
    moves = float(distance_loss(pred, target, rank_on="raw+snapped+moves"))
    assert moves > snapped
    route = torch.zeros(1, 1, 4, 16)
    route[..., 8:12] = 1.0  # the guideline runs through cell 2, where the wrong move is
    assert float(distance_loss(pred, target, rank_on="raw+snapped+moves", route=route)) > moves


def test_ndr_loss_adds_the_distance_term_only_with_its_label():
    logits = torch.zeros(1, 1, 8, 8)
    labels = torch.zeros(1, 1, 8, 8)
    base = ndr_loss(logits, logits, labels, labels)
    target = torch.ones(1, 2, 8, 8)
    assert float(ndr_loss(logits, logits, labels, labels, torch.zeros(1, 1, 8, 8), None)) == float(base)
    assert float(ndr_loss(logits, logits, labels, labels, torch.zeros(1, 1, 8, 8), target)) > float(base)


def test_order_accuracy_on_known_input():
    target = np.array([[0, 1, 2, 3, 4, 5, 6, 7]], np.float32)
    pred = np.array([[0, 1, 2, 3, 4, 9, 6, 7]], np.float32)
    right, total = order_accuracy(pred, target, step=1)
    assert total == 7  # pairs along the row; none along the single-row column axis
    assert right == 6  # only (9, 6) is out of order; (4, 9) still rises as (4, 5) does
    assert order_accuracy(pred, np.full_like(target, -1), step=1) == (0, 0)


def test_warm_start_adds_a_fresh_head_and_train_only_keeps_the_trunk(tmp_path):
    from ndrql.training.loop import train_step
    from ndrql.training.start import freeze_except, warm_start
    from ndrql.training import distributed as D

    plain = build_model(TINY)
    src = save_checkpoint(tmp_path / "plain.pt", {"config": TINY, "model": plain.state_dict()})
    cfg = {**TINY, "distance_head": True}
    model = build_model(cfg)
    warm_start(model, str(src), cfg)
    state = model.state_dict()
    assert all(torch.equal(state[k], v) for k, v in plain.state_dict().items())
    frozen = freeze_except(model, "distance")
    assert frozen and all(not p.requires_grad for m in frozen for p in m.parameters())
    opt = torch.optim.AdamW([p for p in model.parameters() if p.requires_grad], lr=1e-2)
    model.train()
    for m in frozen:
        m.eval()
    x = torch.zeros(2, 3, 64, 64)
    x[:, 0, 20:40, 30:34] = 1.0
    x[:, 1, 32, 4] = 1.0
    x[:, 2, 32, 60] = 1.0
    target = torch.rand(2, 2, 64, 64)
    batch = (x, torch.zeros(2, 1, 64, 64), torch.zeros(2, 1, 64, 64), target)
    head_before = {k: v.clone() for k, v in model.state_dict().items() if k.startswith("distance.")}
    for _ in range(2):
        train_step(model, opt, batch, 1e-2, D.precision_for(torch.device("cpu"), False))
    after = model.state_dict()
    assert all(torch.equal(after[k], v) for k, v in plain.state_dict().items())  # weights and BN statistics
    assert any(not torch.equal(after[k], v) for k, v in head_before.items())
    with pytest.raises(Exception, match="no part"):
        freeze_except(build_model(cfg), "decoder")


def test_distance_head_needs_grid_mode():
    from ndrql.training.config import TrainConfig

    with pytest.raises(ValueError, match="--distance-head needs --input-mode grid"):
        TrainConfig(distance_head=True)


@pytest.mark.parametrize("args, message", [
    (["--distance-head"], "--distance-head needs --input-mode grid"),
    (["--train-only", "decoder"], "--train-only: unknown part decoder; valid: backbone"),
    (["--input-mode", "grid", "--train-only", "distance"], "--train-only distance needs --distance-head"),
    (["--input-mode", "grid", "--distance-decoder", "skips"], "--distance-decoder needs --distance-head"),
    (["--input-mode", "grid", "--distance-head", "--distance-decoder", "unet"], "unknown distance_decoder 'unet'"),
    (["--input-mode", "grid", "--distance-head", "--distance-rank", "snap"], "--distance-rank must be one of raw, raw+snapped, raw+snapped+moves"),
])
def test_train_flags_of_the_distance_head_fail_in_one_line_and_write_nothing(tmp_path, ndrql_exe, args, message):
    from helpers.cli import assert_one_line_error, run_cli

    out = run_cli(ndrql_exe, "train", *args, "--run-dir", str(tmp_path / "run"))
    assert_one_line_error(out, message)
    assert not (tmp_path / "run").exists()
