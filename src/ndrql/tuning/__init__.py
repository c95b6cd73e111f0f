"""Hyper-parameter search of the planners (``ndrql tune``): same budget for every method.

- :mod:`ndrql.tuning.space`: what each method's search explores (one place);
- :mod:`ndrql.tuning.objective`: the validation maps (held-out TRAIN maps only) and the score;
- :mod:`ndrql.tuning.study`: the Optuna study (seeded TPE, constraints, pruning, resumable storage);
- :mod:`ndrql.tuning.report`: per-method outputs, Optuna's plots, the ``tuned`` preset.

Layering: beside :mod:`ndrql.experiments` (it uses its prediction cache); the presets it writes are
read by :mod:`ndrql.planning.preset`, which never imports this package. Optuna is an optional
dependency (``pip install 'ndrql[tune]'``), imported only when a search runs.
"""
