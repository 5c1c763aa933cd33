"""Exact joints: the robot in generalized coordinates (a floating base and one angle per revolute joint)."""
