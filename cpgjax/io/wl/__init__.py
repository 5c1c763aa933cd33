"""The `.wl` description format (thesis Ch. 3.5.1; grammar in docs/wl-format.md).

``parse_wl(text, path)`` / ``load_wl(path)`` give a :class:`cpgjax.sim.description.Description`;
``format_wl`` writes one back; ``load_model(path, dt=, terrain=)`` parses and builds the
simulator's Model (``build_model(load_wl(path), ...)``).

Modules: :mod:`~cpgjax.io.wl.lexer` (tokens, statements, numbers, suggestions),
:mod:`~cpgjax.io.wl.parser` (statement dispatch and blocks), :mod:`~cpgjax.io.wl.checks`
(cross-references, assembly of the Description), :mod:`~cpgjax.io.wl.writer` (``format_wl``).
"""

from cpgjax.io.wl.parser import load_model, load_wl, parse_wl
from cpgjax.io.wl.writer import format_wl

__all__ = ["format_wl", "load_model", "load_wl", "parse_wl"]
