"""The parts of the ``simulator`` node (:mod:`safe_legged_c3bf.nodes.simulator_node`)."""
