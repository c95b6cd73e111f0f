"""Experiments: one module per table or study of the paper, on shared sweeps and reports.

Light on import; the heavy parts (numba, torch, matplotlib, ray) load when an experiment runs.

Tables and studies (each writes ``<target>.md``, ``summary.json`` and figures under its folder):

- :mod:`~ndrql.experiments.table1`, :mod:`~ndrql.experiments.table4`, :mod:`~ndrql.experiments.sizing`:
  the NDR model's F1 (trained runs and their evaluation in :mod:`~ndrql.experiments.model_runs`).
- :mod:`~ndrql.experiments.table2`, :mod:`~ndrql.experiments.table3` (both on
  :mod:`~ndrql.experiments.fixed_maps`), :mod:`~ndrql.experiments.scale`,
  :mod:`~ndrql.experiments.dynamic`: Q-learning methods on dataset maps, many seeds
  (:mod:`~ndrql.experiments.planning_runs`); :mod:`~ndrql.experiments.presets` runs them per preset.
- :mod:`~ndrql.experiments.transfer` (its figures: :mod:`~ndrql.experiments.transfer_report`; the floors of
  large grids and the time per stage: :mod:`~ndrql.experiments.transfer_floors`),
  :mod:`~ndrql.experiments.ceiling`, :mod:`~ndrql.experiments.grid_eval`, :mod:`~ndrql.experiments.labels_check`:
  generated maps the model never trained on, the oracle's ceiling, grid-mode F1, labels.
- :mod:`~ndrql.experiments.eval_sets`: the registry of evaluation sets (``transfer_sets.json``: development and
  sealed roles, digests in ``set_digests.json``); :mod:`~ndrql.experiments.release`: the release report, the only
  reader of a sealed set, counted in a ledger.

Shared pieces, one home each: :mod:`~ndrql.experiments.sweep` (resumable sweeps on the one executor,
:mod:`ndrql.workers`), :mod:`~ndrql.experiments.digests` (fingerprints), :mod:`~ndrql.experiments.report`
(markdown), :mod:`~ndrql.experiments.stats` (mean / median / 95% CI, the paper's improvement, geometric-mean ratios with
bootstrap intervals, clear wins / ties / losses over seeds),
:mod:`~ndrql.experiments.problems` (the fixed maps of Tables 2-3; the problems themselves and their cached
predictions: :mod:`ndrql.pipeline.samples`),
:mod:`~ndrql.experiments.paper` (the paper's numbers, ``paper_numbers.json``). Figures are drawn by
:mod:`ndrql.viz.reproduce`.
"""
