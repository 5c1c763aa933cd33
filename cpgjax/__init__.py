"""cpgjax: genetically evolved CPG control for quadruped walking, after G. Grasso (2000)."""

from cpgjax import _xla

_xla.configure()

__version__ = "0.2.0"
