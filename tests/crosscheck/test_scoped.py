"""crosscheck/scoped.py: a setting held for a ``with`` block."""

import contextvars

import pytest

from cpgjax.crosscheck.scoped import scoped


def test_a_setting_holds_within_its_block_only_and_none_leaves_it():
    var = contextvars.ContextVar("t", default="a")
    with scoped(var, "b"):
        assert var.get() == "b"
        with scoped(var, None):
            assert var.get() == "b"
        with scoped(var, "c"):
            assert var.get() == "c"
        assert var.get() == "b"
    assert var.get() == "a"
    with pytest.raises(RuntimeError), scoped(var, "d"):
        raise RuntimeError("the block fails")
    assert var.get() == "a"
