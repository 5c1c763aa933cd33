"""docs/experiments/coupled_implicit_step.py, the measured prototype of docs/results/engine-agreement.md, still
runs and says what the docs say of it: with pivot springs 10x the thesis's it stands where the explicit step stands (the
statics are exact) and walks the hand-written trot at a 2 ms step, 16x the explicit springs' limit."""

from __future__ import annotations

import importlib
import importlib.util
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from cpgjax.io.ctl import read_ctl
from cpgjax.io.wl.parser import load_model

ROOT = Path(__file__).resolve().parents[1]


def _prototype(monkeypatch):
    spec = importlib.util.spec_from_file_location("coupled_implicit_step",
                                                  ROOT / "docs" / "experiments" / "coupled_implicit_step.py")
    mod = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, mod)      # its dataclass looks its module up there
    spec.loader.exec_module(mod)
    return mod


def _last(model, coeffs, time):
    from cpgjax.episode.rollout import rollout

    out = jax.jit(lambda c: rollout(model, c, time=time, record=True))(coeffs)
    return {k: np.asarray(v) for k, v in out.items() if k != "traj"}, np.asarray(out["traj"]["x"][-1])


@pytest.mark.slow  # 10 s: a prototype in docs/experiments, not the package
def test_the_coupled_implicit_prototype_stands_like_the_explicit_step_and_walks_at_2_ms(monkeypatch):
    proto = _prototype(monkeypatch)
    stiff = ROOT / "models" / "quadruped-stiff.wl"
    explicit = load_model(stiff)                    # its own TimeStep, 0.125 ms
    implicit = load_model(stiff, dt=2e-3)
    trot = read_ctl(ROOT / "models" / "quadruped-trot.ctl").genome.reshape(explicit.n_ctrl, -1)
    coeffs = jnp.asarray(np.stack([np.zeros_like(trot), trot], -1), jnp.float32)
    ref, x_ref = _last(explicit, coeffs[..., :1], 2.0)
    monkeypatch.setattr(importlib.import_module("cpgjax.episode.rollout"), "step", proto.step_implicit)
    out, x = _last(implicit, coeffs, 2.0)
    assert not out["diverged"].any() and not ref["diverged"].any()
    # standing: the same equilibrium (every spring explicit at the start of the step: statics exact)
    assert abs(x[2, explicit.track, 0] - x_ref[2, explicit.track, 0]) < 5e-5
    # the trot walks forward at 2 ms (the explicit springs of this model diverge above 0.2 ms)
    assert out["speed"][1] > 0.08 and not out["fallen"][1]
