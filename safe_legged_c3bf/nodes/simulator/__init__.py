"""The parts of the ``simulator`` node; :mod:`safe_legged_c3bf.nodes.simulator_node` wires them.

* :mod:`.parameters`: the loop's step intervals (the node's parameters are
  :class:`safe_legged_c3bf.sim.node_params.SimulatorParams`);
* :mod:`.physics_loop`: the physics thread (pacing, lockstep, first-command wait);
* :mod:`.command_bus`: /joint_commands, read by the physics thread without an executor;
* :mod:`.state_publisher`: /clock, /odom, /imu, /joint_states (:mod:`.cdr_template`);
* :mod:`.ground_truth_publisher`, :mod:`.detection_publisher`, :mod:`.obstacle_msgs`:
  /ground_truth/*, /obstacles/detections and their obstacle messages;
* :mod:`.sensor_publisher`: /scan and /points of the simulated range sensors;
* :mod:`.quiet_publisher`: publishers without QoS event handlers.

The ROS-free models stay in :mod:`safe_legged_c3bf.sim` (world, perception, range sensors, IMU).
"""
