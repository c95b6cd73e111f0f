"""The planning pipeline on a user's map: map -> planning grid -> model predictions -> runs -> path on the map.

Layering: below :mod:`ndrql.api` and :mod:`ndrql.cli` (which call it), above :mod:`ndrql.maps`,
:mod:`ndrql.model` and :mod:`ndrql.planning` (which it calls); it never imports upwards.

- :mod:`ndrql.pipeline.request`: :class:`PlanRequest`, one plan as one value, and
  :func:`build_request`, the one place its defaults are decided (a map file vs a dataset sample) and its
  input checked; ``ndrql plan``, its batch, ``demo``, ``astar``, ``map info``, ``predict``, the
  environments and the API all build their requests there;
- :mod:`ndrql.pipeline.settings`: :class:`PlanSettings`, how a map becomes a planning problem;
- :mod:`ndrql.pipeline.problem`: reading and checking the map and points (pixels, metres or a MovingAI
  scenario), building the planning grid (the paper's area rule or the safe grid, ``--size auto``, the
  robot's inflation);
- :mod:`ndrql.pipeline.predictions`: the one place that asks the NDR model (or the oracle) for region and
  guideline;
- :mod:`ndrql.pipeline.fallback`: whether the prediction can guide planning, and the method that runs
  instead when it cannot (typed on each run, warned with :class:`~ndrql.errors.FallbackWarning`);
- :mod:`ndrql.pipeline.runs`: the methods and seeds of a plan, each method's priors, the Q-learning runs;
- :mod:`ndrql.pipeline.route`: a learned grid path as a polyline on the full map, its collisions, the
  shortcut path, world poses;
- :mod:`ndrql.pipeline.report`: the stage clock, the runs with their routes, :class:`PlanReport`;
- :mod:`ndrql.pipeline.samples`: dataset samples as planning problems (:class:`Problem`, the one
  problem type of the experiments and the tuning search) and their cached predictions.
"""
