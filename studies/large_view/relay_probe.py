"""A relay from both ends, probed (docs/large-maps.md#what-the-uninformative-maps-have-in-common): on the maps of a
development report that ``plan`` calls uninformative at 256 cells and where both the companion and the base model
are (today's relay runs there), how many the relay serves with 4 and 8 hops from the start, and with a second relay
from the goal (the model asked for the reversed problem, its regions joined with the first's)::

    PYTHONPATH=src python studies/large_view/relay_probe.py large-dev2-256 DIR/summary.json

Not built into ``plan``; one line per map, then the counts.
"""
import json
import sys
import numpy as np
from ndrql.experiments.eval_sets import eval_set, eval_spec
from ndrql.experiments.ceiling import grid_case
from ndrql.experiments.transfer import larger_sizes
from ndrql.experiments.transfer_report import uninformative
from ndrql.model.predict import load_predictor
from ndrql.pipeline.fallback import region_verdict
from ndrql.pipeline.relay import relay
from ndrql.planning.config import PriorConfig
from ndrql.model.weights import resolve_weights

name, summ = sys.argv[1], sys.argv[2]
gs = eval_set(eval_spec(name), False)
recs = [r for r in json.load(open(summ))['records'] if not r.get('skipped') and uninformative(r)]
pred = load_predictor(resolve_weights("general"), 1, "auto", 1)
cfg = PriorConfig()
res = {"current": 0, "hops8": 0, "both": 0, "both8": 0}
for r in recs:
    fam, i, _ = r['key'].rsplit('-', 2)
    raw = gs.raw(int(i))
    c = grid_case(r['key'], fam, raw.obstacles, raw.start, raw.goal, 256, larger_sizes(256))
    b, s, g = c.blocked, c.start_cell, c.goal_cell
    if c.n <= 128: continue
    first = pred.predict_view(b, s, g)
    if region_verdict(first.region, b, s, g, cfg)[2] is None:
        continue
    own = pred.predict_view(b, s, g, companion=False)
    if region_verdict(own.region, b, s, g, cfg)[2] is None:
        continue
    out = {}
    for key, hops in (("current", 4), ("hops8", 8)):
        u, info = relay(pred, b, s, g, first, cfg, max_hops=hops)
        out[key] = info["served"]
    rev = pred.predict_view(b, g, s)
    for key, hops in (("both", 4), ("both8", 8)):
        u1, _ = relay(pred, b, s, g, first, cfg, max_hops=hops)
        u2, _ = relay(pred, b, g, s, rev, cfg, max_hops=hops)
        reg = np.maximum(u1.region, u2.region)
        out[key] = region_verdict(reg, b, s, g, cfg)[2] is None
    for k, v in out.items(): res[k] += v
    print(r['key'], c.n, out, flush=True)
print(len(recs), res)
