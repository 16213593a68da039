"""Gait controllers (no ROS): the A1 convex-MPC trot and the biped ZMP walk."""
