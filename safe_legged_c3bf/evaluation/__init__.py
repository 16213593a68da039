"""Scenario suites and safety evaluation of the node graph.

* :mod:`~safe_legged_c3bf.evaluation.random_scenario`: seeded random scenarios (quadruped and
  biped) with obstacles placed in the robot's way, never on its start or goal.
* :mod:`~safe_legged_c3bf.evaluation.runner`: runs ``python -m safe_legged_c3bf.bringup``
  subprocesses in parallel (each on its own ROS domain), collects their ``report.json`` and
  classifies failures.
* :mod:`~safe_legged_c3bf.evaluation.results`: aggregates the runs into Markdown and CSV
  tables and matplotlib figures; :mod:`~safe_legged_c3bf.evaluation.stats`: the 95 %
  intervals of the rates and the collision-rate bound.
* :mod:`~safe_legged_c3bf.evaluation.campaign`: runs what is left of a campaign
  (:mod:`~safe_legged_c3bf.evaluation.campaign_state`: finished runs, for resuming;
  :mod:`~safe_legged_c3bf.evaluation.progress`: the progress line) on the local pool or on
  Ray (:mod:`~safe_legged_c3bf.evaluation.ray_pool`, with
  :mod:`~safe_legged_c3bf.evaluation.orphan_guard`).

The command line is ``python -m safe_legged_c3bf.evaluate`` (doc/evaluation.md).
"""
