"""``ndrql demo``: QL, IQL and NDR-QL on the bundled sample map, with figures and a table.

The same as ``ndrql plan <bundled map> --compare QL,IQL,NDR-QL --seeds 10`` plus the files a first
look needs: ``compare.png`` (each method's path, the NDR overlay, convergence steps per seed),
``ndr-ql.png`` (the NDR-QL plan alone), ``table.md`` and ``results.json``.
"""

from __future__ import annotations

import argparse
from typing import Any

from ndrql.api import build_request, run_request
from ndrql.cli.common import add_weights_argument, warnings_to_stderr, write_json
from ndrql.cli.options import add_command
from ndrql.cli.plan_cmd import _save, _short, _summary
from ndrql.io import write_text
from ndrql.limits import MAX_WORKERS, check_int, check_seeds
from ndrql.maps.bundled import bundled_sample
from ndrql.planning.results import geometric_ci, summarize
from ndrql.viz.plan import compare_figure, plan_figure

DEMO_METHODS = ("QL", "IQL", "NDR-QL")


def register(subparsers: argparse._SubParsersAction) -> None:
    p = add_command(
        subparsers, "demo", help="QL vs IQL vs NDR-QL on the bundled sample map (figures and a table in out/demo/)",
        description="Plan on the bundled 201x201 sample map (path-planning dataset, TEST/SEEN 906) with QL, "
        "IQL and NDR-QL on the same seeds, print the comparison table and write compare.png, ndr-ql.png, "
        "table.md and results.json.",
        examples="examples:\n  ndrql demo                      # writes out/demo/\n"
        "  ndrql demo --out /tmp/demo --seeds 20")
    p.add_argument("--out", default="out/demo", metavar="DIR", help="output folder (default: out/demo)")
    p.add_argument("--seeds", type=int, default=10, metavar="N", help="seeds 0..N-1 for every method (default: 10)")
    add_weights_argument(p)
    p.add_argument("--workers", type=int, default=None, metavar="N", help="parallel workers (default: all cores)")
    p.add_argument("--preset", default=None, metavar="NAME", help="constants per method: general, spec (the "
                   "paper's), tuned (searched on validation maps with ndrql tune) or a preset FILE (default: what "
                   "ndrql plan uses with the weights)")
    p.set_defaults(func=run)


def table_markdown(report: Any) -> list[str]:
    """A Markdown table of the comparison: convergence, steps, episodes, path ratio per method."""
    def f(v: Any, nd: int = 0) -> str:
        return "-" if v is None else f"{v:,.{nd}f}"

    lines = ["| method | converged | steps, mean | steps, median | steps, 95% CI (geometric) | episodes, mean | path / A* |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for m in report.methods:
        rs = report.runs(m)
        conv = [r for r in rs if r.converged]
        st = summarize([r.convergence_steps for r in conv])
        ep = summarize([r.convergence_episode for r in conv])
        ra = summarize([r.length_ratio for r in conv])
        gci = geometric_ci([r.convergence_steps for r in conv])  # never below zero, as steps are not
        ci = f"{f(gci[0])} - {f(gci[1])}" if gci is not None else "-"
        lines.append(f"| {m} | {len(conv)}/{len(rs)} | {f(st['mean'])} | {f(st['median'])} | {ci} | "
                     f"{f(ep['mean'])} | {f(ra['mean'], 3)} |")
    return lines


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    check_seeds(0, args.seeds)
    if args.workers is not None:
        check_int(args.workers, "--workers", 1, MAX_WORKERS)
    sample = bundled_sample()
    out = Path(args.out)
    with warnings_to_stderr():
        request = build_request(sample.grid_map, sample.start, sample.goal, methods=DEMO_METHODS, seeds=args.seeds,
                                weights=args.weights, preset=args.preset, info=dict(sample.info))
        # as `ndrql plan` runs on a user's map: the safe grid, size auto, plan's preset for the weights
        report = run_request(request, workers=args.workers, progress=True)
    pg = report.grid
    print(f"demo map: {sample.info['source']}")
    print(f"planning grid {pg.shape[0]}x{pg.shape[1]}, start {pg.start} (pixel {sample.start}), "
          f"goal {pg.goal} (pixel {sample.goal}); NDR-QL's priors: "
          f"{(report.info.get('prediction_quality') or {}).get('source') or '-'} ({_short(report.weights or '-')})")
    print("\n".join(_summary(report)))
    table = table_markdown(report)
    head = (f"QL vs IQL vs NDR-QL on the bundled sample map ({sample.info['source']}); seeds 0..{args.seeds - 1}; "
            f"A* optimum {report.astar_length} moves; NDR-QI threshold {report.thresholds.get('NDR-QL')}; "
            f"constants: preset {request.preset.name}.")
    written = [
        _save(compare_figure(report), str(out / "compare.png")),
        _save(plan_figure(report, method="NDR-QL"), str(out / "ndr-ql.png")),
        write_json(out / "results.json", report.to_dict()),
    ]

    written.insert(2, write_text(out / "table.md", head + "\n\n" + "\n".join(table) + "\n"))
    print(f"wrote {', '.join(str(p) for p in written)}")
    return 0
