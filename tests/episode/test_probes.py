"""cpgjax/episode/probes.py: what an episode measures rides the rollout's one scan, probe by probe."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from simcases import box

from cpgjax.episode.probes import Record, Stability
from cpgjax.episode.rollout import episode_length, rollout, schedule


@dataclass(frozen=True)
class Heights:
    """A probe of the caller's own: the samples counted and the box's height summed at each of them."""

    series: ClassVar[bool] = False

    def init(self, ep):
        z = jnp.zeros((ep.s0.x.shape[-1],), ep.s0.x.dtype)
        return {"n": z, "z": z}

    def update(self, ep, acc, smp):
        return {"n": acc["n"] + 1.0, "z": acc["z"] + smp.s.x[2, ep.model.track]}, None

    def finish(self, ep, acc, series, core):
        return {"samples_seen": acc["n"], "mean_height": ep.per_sample(acc["z"])}


def test_a_probe_of_the_callers_own_sees_every_sample_as_the_rollout_does():
    """A box dropped 5 mm onto the ground, 0.5 s at 20 samples/s: a probe written outside the package sees each
    of the 10 samples, and its mean of the height is the rollout's own ``height`` bit for bit (the same sum in
    the same program), with the length compiled in and as data."""
    model = box(z=0.055)
    coeffs = jnp.zeros((model.n_ctrl, model.n_coeff, 4))
    n = schedule(model, 0.5)[1]
    compiled = jax.jit(lambda c: rollout(model, c, time=0.5, probes=(Heights(),)))(coeffs)
    as_data = jax.jit(lambda c, ln: rollout(model, c, length=ln, probes=(Heights(),)))(coeffs,
                                                                                         episode_length(model, 0.5))
    for r in (compiled, as_data):
        assert n == 10 and np.asarray(r["samples_seen"]).tolist() == [10.0] * 4
        np.testing.assert_array_equal(np.asarray(r["mean_height"]), np.asarray(r["height"]))
    assert 0.04 < float(compiled["height"][0]) < 0.06


def test_probes_left_out_add_nothing_and_series_probes_need_the_length_compiled_in():
    model = box(z=0.055)
    coeffs = jnp.zeros((model.n_ctrl, model.n_coeff, 4))
    plain = jax.jit(lambda c: rollout(model, c, time=0.5))(coeffs)
    assert not {"traj", "S", "duty", "heading_fitness", "samples_seen"} & set(plain)
    for probe in (Record(), Stability()):
        with pytest.raises(ValueError, match="per-sample"):
            rollout(model, coeffs, length=episode_length(model, 0.5), probes=(probe,))
