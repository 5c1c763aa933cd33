"""``benchmarks/compile_census.py`` (docs/architecture.md, Tests): the census logs each compile of this process
with its name, times, cache answer, program key and test, stops when closed, and its summary counts a program
compiled twice."""

from __future__ import annotations

import logging

import jax
import numpy as np
import pytest
from benchcases import load_benchmark


@pytest.fixture(scope="module")
def census():
    return load_benchmark("compile_census")


def _program():
    """A new function each call (JAX's in-memory cache misses), the same program."""
    return jax.jit(lambda x: x * 3.0 + 1.0)


def test_each_compile_is_logged_until_closed_and_a_repeat_is_counted(census, tmp_path, capsys):
    logger = logging.getLogger(census.CACHE_LOGGER)
    before = logger.isEnabledFor(logging.DEBUG), logger.propagate, list(logger.handlers)
    c = census.Census(str(tmp_path / "main-1.tsv"))
    x = np.arange(5, dtype=np.float32)
    try:
        _program()(x)
        _program()(x)
    finally:
        c.close()
    _program()(x)                                             # after close: not logged
    assert (logger.isEnabledFor(logging.DEBUG), logger.propagate, list(logger.handlers)) == before
    rows = [line.split("\t") for line in (tmp_path / "main-1.tsv").read_text().splitlines()]
    ours = [r for r in rows if r[0] in ("jit__lambda", "jit(<lambda>)")]   # with the cache on, or off
    assert len(ours) == 2 and len(rows) == 2
    for _name, wall, cpu, hit, _key, test in ours:
        assert float(wall) >= 0 and float(cpu) >= 0 and hit in "01"
        assert test.endswith("test_compile_census.py::test_each_compile_is_logged_until_closed_and_a_repeat_is_"
                             "counted") and test.startswith("tests/benchmarks/")
    assert ours[0][4] == ours[1][4]                           # one program: its key, or "-" with the cache off
    text = census.summary(str(tmp_path))
    assert text.startswith("2 compiles, ")
    if ours[0][4] != "-" and ours[1][3] == "0":               # compiled twice (too small for the cache to keep)
        assert "compiled more than once (in one process or in several): 1," in text
    assert census.main([str(tmp_path), "--top", "3"]) == 0 and capsys.readouterr().out.strip() == text.strip()


def test_a_folder_without_a_census_is_one_line(census, tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        census.main([str(tmp_path)])
    assert e.value.code == 2 and "no .tsv file of the plugin here" in capsys.readouterr().err
