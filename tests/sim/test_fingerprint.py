"""cpgjax/sim/fingerprint.py: a model hashes and compares by its structure, so its programs are cached by it."""

from __future__ import annotations

import jax
import numpy as np
from simcases import box

from cpgjax.episode.batch import simulate
from cpgjax.io.wl import load_model


def test_a_model_loaded_twice_is_the_same_model_and_any_change_makes_another():
    a, b = load_model("models/quadruped.wl", pipeline="exact"), load_model("models/quadruped.wl", pipeline="exact")
    assert a is not b and a == b and hash(a) == hash(b) and len({a, b}) == 1
    assert a.replace(dt=a.dt) == a
    others = [a.replace(dt=0.001), a.replace(gravity=9.8), load_model("models/quadruped.wl"),
              load_model("models/quadruped.wl", pipeline="exact", terrain="rough:0.02:0.1:1"),
              load_model("models/quadruped.wl", pipeline="exact", terrain="rough:0.02:0.1:2")]
    assert len({a, *others}) == 1 + len(others)


def test_a_model_built_again_runs_the_program_compiled_for_the_first():
    """The second of two equal boxes traces no new program (jax.monitoring's trace events: none), and scores the
    same bits; a box 1 mm higher is another model and traces its own."""
    first, again, other = box(z=0.055), box(z=0.055), box(z=0.056)
    zero = np.zeros((4, first.n_ctrl, first.n_coeff), np.float32)
    a = simulate(first, zero, time=0.2)
    traced = []

    def listen(event, _, **kw):
        if "jaxpr_trace" in event:
            traced.append(event)

    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        b = simulate(again, zero, time=0.2)
        assert traced == []
        simulate(other, zero, time=0.2)
        assert traced != []
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)
    for k in ("fitness", "height", "depth"):
        np.testing.assert_array_equal(a[k], b[k])
