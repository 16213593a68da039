"""Scenario suites and safety evaluation of the node graph.

* :mod:`~safe_legged_c3bf.evaluation.random_scenario`: seeded random scenarios (quadruped and
  biped) with obstacles placed in the robot's way, never on its start or goal.
* :mod:`~safe_legged_c3bf.evaluation.runner`: runs ``python -m safe_legged_c3bf.bringup``
  subprocesses in parallel (each on its own ROS domain), collects their ``report.json`` and
  classifies failures.
* :mod:`~safe_legged_c3bf.evaluation.results`: aggregates the runs into Markdown and CSV
  tables and matplotlib figures.

The command line is ``python -m safe_legged_c3bf.evaluate`` (doc/evaluation.md).
"""
