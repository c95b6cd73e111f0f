"""Experiments: one function per table or figure of the paper, plus sweeps and executors.

Light on import; the heavy parts (numba, torch, matplotlib, ray) load when an experiment runs.

- :mod:`~ndrql.experiments.stats`: mean / median / 95% CI, relative improvement as the paper reports it.
- :mod:`~ndrql.experiments.sweep`: resumable sweeps (one atomic JSON per finished task) on a
  process pool, serially, or on Ray.
- :mod:`~ndrql.experiments.problems`: dataset samples as planning problems, cached NDR predictions.
- :mod:`~ndrql.experiments.planning_tables`: Tables 2 and 3 and the ``scale`` study.
- :mod:`~ndrql.experiments.dynamic`: the dynamic scenarios of Fig. 5.
- :mod:`~ndrql.experiments.model_tables`: Tables 1 and 4 (the NDR model's F1).
"""
