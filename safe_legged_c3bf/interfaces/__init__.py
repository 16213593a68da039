"""The contract between the parts: topics, robot state, commands, rotations, parameters."""
