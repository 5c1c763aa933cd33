"""A smoke run of ``benchmarks/compile_anatomy.py`` (docs/results/performance-exact.md, *Compile*): a small program's
kernels found in XLA's dump, each with its kind and the line of this file that made it."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import pytest
from benchcases import load_benchmark


def _stacked(x):
    return jnp.stack([x * 2.0 + 1.0, jnp.sin(x) * x, -x])             # a concatenate fusion (line 13)


def test_a_programs_kernels_are_found_with_their_kind_and_source_line(tmp_path):
    bench = load_benchmark("compile_anatomy")
    lowered = jax.jit(_stacked).lower(jnp.ones((3, 16), jnp.float32))
    result = bench.anatomy(lowered, str(tmp_path), root=str(tmp_path))
    assert result["compile_s"] > 0 and result["kernels"]
    sizes = [k[2] for k in result["kernels"]]
    assert sizes == sorted(sizes, reverse=True) and min(sizes) > 0
    assert any(kd == "concatenate" and src.endswith("test_compile_anatomy.py:13 _stacked")
               for _, kd, _, src in result["kernels"]), result["kernels"]
    lines = bench.table(result, top=3)
    assert lines[0].startswith("compile: ") and f"{len(result['kernels'])} kernels" in lines[0]
    assert "| kind | kernels | IR [MB] | share |" in lines and "| source line | kernels | IR [MB] | share |" in lines


def test_kinds_are_read_off_the_fusions_names():
    bench = load_benchmark("compile_anatomy")
    assert bench.kind("bitcast_concatenate_fusion.5") == "concatenate"
    assert bench.kind("dynamic_update_slice_fusion.2") == "dynamic-update-slice"
    assert bench.kind("add_rsqrt_fusion") == "elementwise"


def test_bad_arguments_exit_2(capsys):
    bench = load_benchmark("compile_anatomy")
    for argv in (["no/such.wl"], ["--batch", "0"]):
        with pytest.raises(SystemExit) as e:
            bench.main(argv)
        assert e.value.code == 2
    assert "no/such.wl: no such model file" in capsys.readouterr().err


def test_the_program_dissected_is_the_benchs():
    """`main`'s program is `cpgjax bench`'s: the same lowered episode for the same robots (not compiled)."""
    from cpgjax.experiments.bench import episode_program
    from cpgjax.io.wl import load_model

    bench = load_benchmark("compile_anatomy")
    ours = bench.episode_program("models/worm.wl", None, 3, 0.3)
    f, coeffs = episode_program(load_model("models/worm.wl"), 3, 0.3)
    assert coeffs.shape[0] == 3 and ours.as_text() == f.lower(coeffs).as_text()
