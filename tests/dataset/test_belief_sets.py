"""Training pairs on belief maps (issue 54): sets drawn with --masks, their rendering and their batches."""

from __future__ import annotations

import numpy as np
import pytest

from ndrql.dataset.encodings import encode_input
from ndrql.dataset.generated import GeneratedSet, generate_set, shard_path
from ndrql.dataset.mixture import Mixture, SourceSpec, generated_source, stack
from ndrql.dataset.render import PX_PER_CELL, belief_grids, goal_distance_pixels, render_belief_grid, render_grid
from ndrql.errors import NdrqlError
from ndrql.maps import sizing
from ndrql.maps.belief import Belief, unknown_cells
from ndrql.synth.belief_sets import draw_training_belief, parse_masks
from ndrql.synth.generate import SetSpec
from ndrql.synth.oracle import oracle_prediction


def _walled():
    """A 64 px map, a wall across the middle with a gap on the far right; start above it, goal below it, on the
    left. The belief hides the wall's left part (unknown, so the planner counts it free)."""
    truth = np.zeros((64, 64), bool)
    truth[30:34, :52] = True
    unknown = np.zeros((64, 64), bool)
    unknown[24:40, 0:36] = True
    return truth, Belief(truth, unknown, kind="blobs"), (8, 10), (56, 10)


def test_labels_come_from_the_true_map_and_the_unknown_channel_is_the_mask():
    truth, belief, start, goal = _walled()
    n = 16
    r = render_belief_grid(truth, belief.obstacles, belief.unknown, start, goal, n)
    assert r is not None
    tpg = sizing.safe_grid(truth, n, start, goal)
    bpg = sizing.safe_grid(belief.obstacles, n, start, goal)
    s, g = tpg.start, tpg.goal
    # input: the belief's grid (the hidden wall is not there)
    np.testing.assert_array_equal(r.obstacles[:n * 4, :n * 4], np.kron(bpg.blocked, np.ones((4, 4), bool)))
    assert not bpg.blocked[8, 2] and tpg.blocked[8, 2]
    # labels: the true grid's route and distances, not the belief's
    region, guide = oracle_prediction(tpg.blocked, s, g, PX_PER_CELL)
    np.testing.assert_array_equal(r.region, region > 0.5)
    np.testing.assert_array_equal(r.guideline, guide > 0.5)
    np.testing.assert_array_equal(r.distance, goal_distance_pixels(tpg.blocked, g, n * 4))
    _, believed_guide = oracle_prediction(bpg.blocked, s, g, PX_PER_CELL)
    assert not np.array_equal(r.guideline, believed_guide > 0.5)  # the belief's own route crosses the hidden wall
    # the unknown channel: the planning cells holding an unknown pixel, where the belief's grid is free
    cells = unknown_cells(belief.unknown, tpg) & ~bpg.blocked
    assert cells.sum() > 0
    np.testing.assert_array_equal(r.unknown, np.kron(cells, np.ones((4, 4), bool)))
    x = stack([r], "point+unknown")[0]
    np.testing.assert_array_equal(x[0, 3].numpy(), r.unknown.astype(np.float32))
    assert stack([r], "point")[0].shape[1] == 3  # a model without the channel sees the belief alone


def test_a_known_belief_renders_as_the_known_map():
    truth, _, start, goal = _walled()
    r = render_belief_grid(truth, truth, np.zeros_like(truth), start, goal, 16)
    plain = render_grid(truth, start, goal, 16)
    for key in ("obstacles", "region", "guideline", "distance"):
        np.testing.assert_array_equal(getattr(r, key), getattr(plain, key))
    assert not r.unknown.any()


def test_a_belief_that_does_not_connect_is_skipped():
    truth, _, start, goal = _walled()
    believed = truth.copy()
    believed[30:34, :] = True  # an outdated map: the gap closed
    assert belief_grids(truth, believed, np.zeros_like(truth), start, goal, 16) is None
    assert render_belief_grid(truth, believed, np.zeros_like(truth), start, goal, 16) is None


@pytest.mark.parametrize("text, message", [("fog", "lists kinds"), ("blobs:0.6-0.2", "LO <= HI"),
                                           ("blobs,none:1.5", "SHARE < 1"), ("sensed:3", "takes no argument"),
                                           ("blobs:x", "must be a number"), ("blobs,blobs", "each once")])
def test_bad_mask_specs_are_one_clear_error(text, message):
    with pytest.raises(NdrqlError, match=message):
        parse_masks(text)


def test_mask_spec_spelling_and_draws_by_seed():
    spec = parse_masks("blobs:0.1-0.5, sensed,outdated")
    assert str(spec) == "blobs:0.1-0.5,sensed,outdated,none:0.2"
    truth, _, start, goal = _walled()
    kinds = [draw_training_belief(spec, truth, start, goal, 3, i).kind for i in range(40)]
    assert set(kinds) == {"known", "blobs", "sensed", "outdated"}
    again = [draw_training_belief(spec, truth, start, goal, 3, i) for i in range(6)]
    for i, b in enumerate(again):
        c = draw_training_belief(spec, truth, start, goal, 3, i)
        assert b.kind == c.kind and np.array_equal(b.unknown, c.unknown) and np.array_equal(b.obstacles, c.obstacles)
        assert not b.unknown[start] and not b.unknown[goal]
    assert all(draw_training_belief(parse_masks("blobs,none:0"), truth, start, goal, 3, i).kind == "blobs"
               for i in range(5))


SPEC = SetSpec(("office", "bugtrap"), (64,), 10, 5, "blobs:0.2-0.4,outdated,none:0.3", 7)


def test_generated_set_with_beliefs_is_deterministic_and_keeps_the_maps(tmp_path):
    a = generate_set(tmp_path / "a", SPEC, progress=False)
    b = generate_set(tmp_path / "b", SPEC, workers=2, progress=False)
    plain = generate_set(tmp_path / "plain", SetSpec(("office", "bugtrap"), (64,), 10, 5), progress=False)
    assert shard_path(a, 0).read_bytes() == shard_path(b, 0).read_bytes()
    gs, gp = GeneratedSet.load(a), GeneratedSet.load(plain)
    assert gp.belief(0) is None
    kinds = set()
    for i in range(len(gs)):
        assert np.array_equal(gs.raw(i).obstacles, gp.raw(i).obstacles)  # the same maps as the plain set
        belief = gs.belief(i)
        want = draw_training_belief(parse_masks(SPEC.masks), gs.raw(i).obstacles, gs.raw(i).start, gs.raw(i).goal, 7, i)
        assert belief.kind == want.kind and np.array_equal(belief.unknown, want.unknown)
        assert np.array_equal(belief.obstacles, want.obstacles)
        kinds.add(belief.kind)
    assert "known" in kinds and len(kinds) >= 2


def test_mixture_of_a_belief_set_feeds_the_unknown_channel(tmp_path):
    root = generate_set(tmp_path / "s", SPEC, progress=False)
    src = generated_source(SourceSpec(str(root), 1.0))
    mix = Mixture([src], "grid", (16,), "point+unknown", distance=True)
    x, region, guide, dist = mix.batch(0, 0, 0, 4)
    assert x.shape[1] == 4 and set(np.unique(x[:, 3].numpy())) <= {0.0, 1.0}
    assert bool((x[:, 3] * x[:, 0]).eq(0).all())  # unknown only where the belief's grid is free
    with pytest.raises(NdrqlError, match="native view"):
        from ndrql.dataset.views import GridView

        Mixture([src], "grid", (16,), "point+unknown", view=GridView.parse("cap:32")).batch(0, 0, 0, 2)


def test_mask_seeds_follow_the_training_range(tmp_path):
    bad = SetSpec(("office",), (64,), 2, 5, "blobs", 950_001)
    with pytest.raises(NdrqlError, match="--mask-seed 950001 is not a training seed"):
        generate_set(tmp_path / "x", bad, progress=False)
    assert not (tmp_path / "x").exists()


def test_encode_input_of_a_view_with_unknown_cells_matches_the_render():
    """What ``plan`` feeds the model (the view's input of the belief grid and its unknown cells) is what training
    feeds it (:func:`render_belief_grid`)."""
    from ndrql.dataset.views import view_input

    truth, belief, start, goal = _walled()
    true_blocked, seen, unknown, s, g = belief_grids(truth, belief.obstacles, belief.unknown, start, goal, 16)
    r = render_belief_grid(truth, belief.obstacles, belief.unknown, start, goal, 16)
    vi = view_input(seen, s, g, unknown=unknown)
    np.testing.assert_array_equal(encode_input(vi.image, vi.start, vi.goal, "point+unknown", vi.unknown),
                                  encode_input(r.obstacles, r.start, r.goal, "point+unknown", r.unknown))


def test_data_cli_generates_beliefs_and_refuses_bad_ones(tmp_path, ndrql_exe):
    from helpers.cli import assert_one_line_error, run_cli

    base = ("data", "generate", "--family", "office", "--count", "2", "--size", "64", "--seed", "5", "--no-progress")
    res = run_cli(ndrql_exe, *base, "--masks", "blobs:0.2-0.3", "--mask-seed", "9", "--out", tmp_path / "ok")
    assert res.returncode == 0, res.stderr
    assert "beliefs blobs:0.2-0.3,none:0.2 (mask seed 9)" in res.stdout
    assert GeneratedSet.load(tmp_path / "ok").belief(0) is not None
    for extra, needle in ((("--masks", "fog"), "lists kinds"), (("--masks", "blobs:0.2-x"), "must be a number"),
                          (("--mask-seed", "3"), "give --masks too"),
                          (("--masks", "blobs", "--mask-seed", "900001"), "--mask-seed 900001 is not a training seed")):
        res = run_cli(ndrql_exe, *base, *extra, "--out", tmp_path / "bad")
        assert_one_line_error(res, needle)
        assert not (tmp_path / "bad").exists()
