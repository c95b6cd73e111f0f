"""``ndrql reproduce labels``: the map engine's labels checked against the path-planning dataset.

Three questions, answered on TEST/SEEN (all 1,200 samples, or ``limit`` spread evenly over them):

1. **Is the label definition the dataset's?** Our drawing of each sample's own RRT* waypoints
   (:func:`ndrql.synth.labels.draw_guideline`) against its ``PATH [2PIXEL]`` image, and our dilation
   of that image (:func:`ndrql.synth.labels.dilate_region`) against its ``PATH [30PIXEL]`` image:
   the number of pixel-exact samples.
2. **How close are labels from our planner?** :func:`ndrql.synth.labels.make_labels` from the
   sample's own start and goal on its own 201x201 map, scored against the dataset's labels with the
   paper's per-image F1 (mean per category), and the length of our polyline against the length of
   the dataset's (quantiles, how often ours is shorter).
3. **Are our endpoints like the dataset's?** :func:`ndrql.synth.endpoints.sample_endpoints` on the
   same maps (seeded per map), start-goal distance and path length against the dataset's pairs.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from ndrql.dataset.layout import CATEGORIES, check_root, count_samples, default_root, load_sample
from ndrql.errors import DatasetError, NoPathError
from ndrql.experiments.report import machine, machine_line, md_table
from ndrql.io import make_folder, write_json, write_text
from ndrql.maps.lines import polyline_length
from ndrql.synth.endpoints import sample_endpoints
from ndrql.synth.labels import dilate_region, draw_guideline, make_labels, near_optimal_path
from ndrql.training.metrics import f1_per_image

SPLIT = "seen"
QUANTILES = (0.0, 0.05, 0.25, 0.5, 0.75, 0.95, 1.0)

WHY = (
    "Why ours and the dataset's differ: the dataset's paths are RRT* (near-optimal: a random tree stopped "
    "after a budget), ours are the octile-shortest grid path shortcut greedily by line of sight, so ours is "
    "usually shorter. Not always: greedy shortcutting of a grid path does not always reach the taut any-angle "
    "path, our segments keep off obstacle pixels entirely (not even touching a corner) while the dataset's "
    "collision test truncates coordinates and lets paths graze obstacle edges, and the octile-shortest path can "
    "pass an obstacle on the other side than the any-angle shortest one. Where two ways round an obstacle have "
    "similar lengths the planners may choose differently and that sample's region F1 drops towards 0. Near "
    "walls the two paths run a pixel or two apart, which is why the 2 px guideline F1 stays well below the "
    "30 px region F1."
)
ENDPOINTS_NOTE = (
    "sample_endpoints draws uniformly under the dataset's stated rules (start in the top half, goal in the "
    "bottom half, opposite column halves, at least 0.75 x the map side apart, joined by a path); the dataset's "
    "own pairs lie farther apart than those rules require, because its starts and goals cluster near the corners."
)


@dataclass(frozen=True)
class SampleCheck:
    """One sample's comparison (lengths in pixels, F1 in [0, 1])."""

    index: int
    category: str
    draw_exact: bool
    """Our drawing of the dataset's waypoints equals its guideline image."""
    dilate_exact: bool
    """Our dilation of its guideline equals its region image."""
    has_path: bool
    """Our planner joined start and goal (False: 4-connected free space separates them)."""
    region_f1: float
    guide_f1: float
    ours_length: float
    dataset_length: float
    distance: float
    """Straight start-goal distance of the sample."""
    sampler_distance: float
    """Start-goal distance of the pair :func:`sample_endpoints` drew on this map (nan: none)."""
    sampler_length: float
    """Our path length for that pair (nan: none)."""


def f1(pred: np.ndarray, label: np.ndarray) -> float:
    """Pixel F1 of one image (the paper's per-image F1, :mod:`ndrql.training.metrics`)."""
    return float(f1_per_image(pred[None], label[None])[0])


def sample_indices(limit: int | None, n: int) -> list[int]:
    """All ``n`` indices, or ``limit`` of them spread evenly (so every category block is sampled)."""
    if limit is None or limit >= n:
        return list(range(n))
    return sorted({int(round(v)) for v in np.linspace(0, n - 1, max(int(limit), 1))})


def check_sample(root: str | Path, index: int, seed: int) -> SampleCheck:
    """Compare our labels, lengths and endpoints with dataset sample ``index`` of TEST/SEEN."""
    s = load_sample(root, SPLIT, index)
    draw_exact = bool(np.array_equal(draw_guideline(s.map.shape, s.waypoints), s.guideline))
    dilate_exact = bool(np.array_equal(dilate_region(s.guideline), s.region))
    nan = float("nan")
    try:
        ours = make_labels(s.map, s.start, s.goal)
        has_path, region_f1, guide_f1 = True, f1(ours.region, s.region), f1(ours.guideline, s.guideline)
        ours_length = polyline_length(ours.waypoints)
    except NoPathError:
        has_path, region_f1, guide_f1, ours_length = False, nan, nan, nan
    pair = sample_endpoints(np.random.default_rng([seed, index]), s.map)
    if pair is None:
        sampler_distance = sampler_length = nan
    else:
        (sr, sc), (gr, gc) = pair
        sampler_distance = math.hypot(gr - sr, gc - sc)
        sampler_length = polyline_length(near_optimal_path(s.map, *pair))
    return SampleCheck(
        index=index, category=s.category, draw_exact=draw_exact, dilate_exact=dilate_exact, has_path=has_path,
        region_f1=region_f1, guide_f1=guide_f1, ours_length=ours_length,
        dataset_length=polyline_length(s.waypoints),
        distance=math.hypot(s.goal[0] - s.start[0], s.goal[1] - s.start[1]),
        sampler_distance=sampler_distance, sampler_length=sampler_length,
    )


def _quantile_row(name: str, values: list[float]) -> list[str]:
    v = np.asarray([x for x in values if x == x], dtype=np.float64)
    if len(v) == 0:
        return [name, "0"] + ["-"] * len(QUANTILES)
    return [name, str(len(v))] + [f"{q:.1f}" for q in np.quantile(v, QUANTILES)]


def tables(checks: list[SampleCheck]) -> str:
    """The markdown report: label definition, F1 and lengths per category, length quantiles."""
    n = len(checks)
    out = [
        f"Label definition, on the dataset's own paths ({n} TEST/SEEN samples): our drawing of its waypoints "
        f"equals its `PATH [2PIXEL]` image in {sum(c.draw_exact for c in checks)}/{n} samples, our dilation of "
        f"that image equals its `PATH [30PIXEL]` image in {sum(c.dilate_exact for c in checks)}/{n}.",
        "",
        "Labels from our planner (A* + shortcut from the sample's own start and goal) against the dataset's:",
        "",
    ]
    rows = []
    for cat in (*CATEGORIES[SPLIT], "all"):
        sel = [c for c in checks if cat in ("all", c.category)]
        ok = [c for c in sel if c.has_path]
        if not sel:
            continue
        ratio = [c.ours_length / c.dataset_length for c in ok]
        rows.append([
            cat, str(len(sel)), str(len(sel) - len(ok)),
            f"{np.mean([c.region_f1 for c in ok]):.3f}" if ok else "-",
            f"{np.mean([c.guide_f1 for c in ok]):.3f}" if ok else "-",
            f"{100 * np.mean([r < 1 - 1e-9 for r in ratio]):.1f}" if ok else "-",
            f"{np.mean(ratio):.3f}" if ok else "-",
            f"{np.min(ratio):.3f} - {np.max(ratio):.3f}" if ok else "-",
        ])
    out.append(md_table(["category", "samples", "no path", "region F1", "guideline F1", "ours shorter (%)",
                         "ours / dataset length", "range"], rows))
    out += ["", "Path lengths and start-goal distances (px) as quantiles:", ""]
    header = ["", "n"] + [f"q{int(100 * q)}" if 0 < q < 1 else ("min" if q == 0 else "max") for q in QUANTILES]
    out.append(md_table(header, [
        _quantile_row("dataset path (RRT* waypoints)", [c.dataset_length for c in checks]),
        _quantile_row("our path, same start and goal", [c.ours_length for c in checks]),
        _quantile_row("dataset start-goal distance", [c.distance for c in checks]),
        _quantile_row("sample_endpoints start-goal distance", [c.sampler_distance for c in checks]),
        _quantile_row("our path, sample_endpoints pair", [c.sampler_length for c in checks]),
    ]))
    ok = [c for c in checks if c.has_path]
    excess = [100 * (c.ours_length / c.dataset_length - 1) for c in ok if c.ours_length > c.dataset_length + 1e-9]
    out += ["", f"Ours is longer than the dataset's in {len(excess)}/{len(ok)} samples"
            + (f" (median excess {np.median(excess):.2f} %, largest {max(excess):.2f} %)" if excess else "")
            + f"; region F1 is below 0.5 in {sum(c.region_f1 < 0.5 for c in ok)} (another way round an obstacle).",
            "", WHY, "", ENDPOINTS_NOTE]
    return "\n".join(out) + "\n"


def labels_check(out: str | Path, data: str | Path | None = None, limit: int | None = None, seed: int = 0,
                 command: str = "", progress: bool = True, log: Callable[[str], None] = print) -> Path:
    """Run the check on TEST/SEEN and write ``labels.md`` and ``summary.json`` under ``out``."""
    root = data or default_root()
    if root is None:
        raise DatasetError("dataset not found; pass --data DIR (the path-planning-dataset root)")
    root = check_root(root)
    indices = sample_indices(limit, min(count_samples(root, SPLIT), 1200))
    log(f"labels: {len(indices)} TEST/SEEN samples from {root}, endpoint seed {seed}")
    items = indices
    if progress:
        from tqdm import tqdm

        items = tqdm(indices, desc="labels", unit="sample")
    checks = [check_sample(root, i, seed) for i in items]
    info = machine()
    text = tables(checks)
    header = f"# Labels check\n\n`{command or 'ndrql reproduce labels'}`\n\n{machine_line(info)}\n\n"
    folder = make_folder(out)
    write_text(folder / "labels.md", header + text)
    write_json(folder / "summary.json", {"command": command, "machine": info, "seed": seed,
                                         "samples": [asdict(c) for c in checks]}, strict=False)
    log(text)
    return folder / "labels.md"
