"""Planning tasks for the sweep tests, also built by the child process of the kill-and-resume test."""

from __future__ import annotations

import numpy as np

from ndrql.experiments.planning_runs import SweepOptions, make_tasks
from ndrql.experiments.sweep import Task
from ndrql.maps.problem import MapProblem
from ndrql.pipeline.samples import Problem
from ndrql.planning.methods import Method, get_method


def slow_tasks() -> list[Task]:
    """40 planning tasks of a few tenths of a second each (plain QL on an open 40x40 grid)."""
    opts = SweepOptions(seeds=4, progress=False)
    probs = []
    for k in range(10):
        b = np.zeros((40, 40), bool)
        b[20, 5 + k: 35] = True
        probs.append(Problem("kill", k, "wall", MapProblem(b, (0, 0), (39, 39)), b, (0, 0), (39, 39), 78))
    variants = [get_method("QL"), get_method("D-Q"), get_method("IQL"), Method("D-C", d_crf=True)]
    return make_tasks(probs, variants, opts, None, records=False)
