"""Replay a recording's sensor, odometry and reference topics into the safety pipeline.

``python -m safe_legged_c3bf.replay RECORDING.mcap`` plays an MCAP recording (the bringup's
``--record``) into the obstacle detector, tracker and filter without the simulator, and scores
the filtered command against ground truth (:mod:`.kpis`): reaction time to a cone entry, time
to leave the cone, false interventions on a free path.
"""
