"""The independent cross-check: export to MJCF, run MuJoCo C / MJX, compare with the penalty simulator.

:mod:`~cpgjax.crosscheck.mjcf` (export), :mod:`~cpgjax.crosscheck.engines` (MuJoCo C and MJX
runs with our metrics), :mod:`~cpgjax.crosscheck.compare` (``cpgjax crosscheck``).
"""
