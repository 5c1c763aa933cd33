"""The `.wl` description format (thesis Ch. 3.5.1; grammar in docs/wl-format.md).

``parse_wl(text, path)`` / ``load_wl(path)`` give a :class:`cpgjax.sim.description.Description`;
``format_wl`` writes one back; ``load_model(path)`` parses and builds the simulator's Model.
"""

from cpgjax.io.wl.parser import format_wl, load_model, load_wl, parse_wl

__all__ = ["format_wl", "load_model", "load_wl", "parse_wl"]
