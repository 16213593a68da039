"""safe_legged_c3bf: a Collision Cone CBF safety filter for legged robots, as a ROS 2 node graph.

Algorithms (barrier functions, QP, MPC, preview control, Kalman filter, kinematics) live in
plain numpy modules with no rclpy import; ``safe_legged_c3bf.nodes`` holds the thin rclpy
wrappers. Units are SI and frames follow REP-103/REP-105 (x forward, z up, odom -> base_link).
"""

__version__ = "0.1.0"
