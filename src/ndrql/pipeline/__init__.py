"""The planning pipeline on a user's map: map -> planning grid -> model predictions -> runs -> path on the map.

Layering: below :mod:`ndrql.api` and :mod:`ndrql.cli` (which call it), above :mod:`ndrql.maps`,
:mod:`ndrql.model` and :mod:`ndrql.planning` (which it calls); it never imports upwards.

- :mod:`ndrql.pipeline.settings`: :class:`PlanSettings`, how a map becomes a planning problem;
- :mod:`ndrql.pipeline.problem`: reading and checking the map and points, building the planning grid
  (the paper's area rule or the safe grid, ``--size auto``, the robot's inflation);
- :mod:`ndrql.pipeline.predictions`: the one place that asks the NDR model for region and guideline;
- :mod:`ndrql.pipeline.route`: a learned grid path as a polyline on the full map, its collisions, the
  shortcut path, world poses.
"""
