"""What an episode measures beside its fitness: small probes that ride the rollout's one scan.

:func:`cpgjax.episode.rollout.rollout` runs one scan over the log samples.  It carries the state, eq. 4.6's
fitness and the episode's health (falls, divergence, depth), and what each probe the caller passes accumulates.
A probe is a frozen value with three pure functions:

- ``init(ep) -> acc``: its sums at t = 0 (``ep``: the :class:`Episode`);
- ``update(ep, acc, smp) -> (acc, out)``: at each log sample (``smp``: the :class:`Sample`), its new sums and a
  per-sample output (None: none);
- ``finish(ep, acc, series, core) -> dict``: the results it adds (``series``: its per-sample outputs stacked
  along a first axis, None without any; ``core``: the rollout's own sums at the end, e.g. ``diverged``).

A probe whose ``series`` is True returns per-sample arrays, whose shape needs the episode's length compiled in
(``rollout(time=...)``, not ``length=``).

The probes: :class:`Record` (the trajectory), :class:`Stability` (thesis Ch. 6.4's two stability measures at
every sample), :class:`Descriptors` (the repertoire's behaviour descriptors, :mod:`cpgjax.episode.descriptors`)
and :class:`Tracking` (a steering :class:`~cpgjax.episode.steering.Schedule`'s tracking sums, which the rollout
adds itself when the command follows one).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple

import jax
import jax.numpy as jnp

from cpgjax.episode import descriptors as bd
from cpgjax.episode import steering as st
from cpgjax.episode.fitness import stability, up_cos
from cpgjax.episode.support import projection_stability
from cpgjax.sim.contact import terrain_under
from cpgjax.sim.rotation import quat_to_mat
from cpgjax.sim.state import State, sim_time


class Episode(NamedTuple):
    """What a probe may read of the episode as a whole."""

    model: Any
    s0: State                 # the initial state
    var: Any                  # the per-robot Variation, or None
    delta: float              # eq. 6.2's delta
    steer: Any                # the closed loop's command (a Schedule, a Course) or None
    sample: Callable          # (state, R, closed-loop memory) -> the recorded sample (a dict of [.., B])
    cl0: Any                  # the closed loop's memory at t = 0 (None: open loop)
    outer: Any                # the log samples (an int, or traced with ``length``)
    per_sample: Callable      # a sum over the samples -> its mean
    per_second: Callable      # a sum over the episode's seconds -> per second
    T: float | None           # the episode's seconds where compiled in, else None
    length: dict | None       # the length as data (rollout.episode_length), else None


class Sample(NamedTuple):
    """One log sample, as the rollout computed it for its own sums."""

    s: State                  # the state (kept at the last good sample where it diverged)
    R: jax.Array              # [3, 3, nb, B] body rotations
    p: jax.Array              # [3, npt, B] world points
    zg: jax.Array | None      # [nc, B] the terrain under the contact vertices (None on flat ground)
    cosu: jax.Array           # [B] cos of the tracked body's tilt
    ok: jax.Array             # [B] this sample is healthy
    was_down: jax.Array       # [B] fallen before this sample (fall_ends)
    cl: Any                   # the closed loop's memory (None: open loop)

    def touching(self, model):
        """[nc, B] which contact vertices are in the ground (depth > 0, the contact law's own test)."""
        if self.zg is None:
            return self.p[2, model.ct_pt] < 0
        return self.zg - self.p[2, model.ct_pt] > 0


def stability_measures(model, s: State, p, var, delta):
    """The two stability measures of one sample (thesis Ch. 6.4): vestibular S(theta) and projection.

    Vestibular: eq. 6.2 on the tracked body's tilt.  Projection (:mod:`cpgjax.episode.support`): the signed
    distance of the whole robot's CM, projected on the ground, to the support polygon of the contact vertices
    touching the terrain (depth > 0, the contact law's own test), over the CM's height above the terrain
    under it; NaN with fewer than three vertices down.  Returns (S, projection, vertices down), each [B].
    """
    m = jnp.asarray(model.mass, s.x.dtype)[:, None]
    if var is not None:
        m = m * var.mass
    cm = jnp.sum(m * s.x, axis=1) / jnp.sum(m, axis=0)            # [3, B]
    cp = p[:, model.ct_pt]                                         # [3, nc, B]
    if model.terrain.flat:
        zc, zcm = jnp.zeros_like(cp[2]), jnp.zeros_like(cm[2])
    else:
        zc, _ = terrain_under(model, cp[0], cp[1], var)
        zcm, _ = terrain_under(model, cm[0], cm[1], var)
    proj, n_down = projection_stability(cp[0], cp[1], zc - cp[2] > 0, (cm[0], cm[1], cm[2] - zcm))
    return stability(up_cos(model, s.q), delta), proj, n_down


@dataclass(frozen=True)
class Record:
    """The trajectory: ``traj`` with the initial state's sample first, ``[samples + 1, ...]``
    (:func:`cpgjax.episode.rollout.rollout` says its keys)."""

    series: ClassVar[bool] = True

    def init(self, ep):
        return ()

    def update(self, ep, acc, smp):
        return acc, ep.sample(smp.s, smp.R, smp.cl)

    def finish(self, ep, acc, series, core):
        first = ep.sample(ep.s0, quat_to_mat(ep.s0.q), ep.cl0)
        return {"traj": jax.tree.map(lambda a0, a: jnp.concatenate([a0[None], a]), first, series)}


@dataclass(frozen=True)
class Stability:
    """Thesis Ch. 6.4 at every log sample (:func:`stability_measures`): ``S`` and ``proj`` [samples, B]
    (vestibular and projection stability, NaN where the latter is undefined), ``S_mean``, ``proj_mean`` (over the
    defined samples; NaN if none), ``proj_min`` and ``proj_undefined`` (samples with fewer than three vertices
    down)."""

    series: ClassVar[bool] = True

    def init(self, ep):
        z = jnp.zeros((ep.s0.x.shape[-1],), ep.s0.x.dtype)
        return {"S": z, "proj": z, "proj_n": jnp.zeros(z.shape, jnp.int32), "proj_min": z + jnp.inf}

    def update(self, ep, acc, smp):
        S_t, proj_t, _ = stability_measures(ep.model, smp.s, smp.p, ep.var, ep.delta)
        defined = jnp.isfinite(proj_t)
        acc = {"S": acc["S"] + S_t, "proj": acc["proj"] + jnp.where(defined, proj_t, 0.0),
               "proj_n": acc["proj_n"] + defined,
               "proj_min": jnp.minimum(acc["proj_min"], jnp.where(defined, proj_t, jnp.inf))}
        return acc, {"S": S_t, "proj": proj_t}

    def finish(self, ep, acc, series, core):
        n = acc["proj_n"]
        return {"S": series["S"], "proj": series["proj"], "S_mean": acc["S"] / ep.outer,
                "proj_mean": jnp.where(n > 0, acc["proj"] / jnp.maximum(n, 1), jnp.nan),
                "proj_min": jnp.where(n > 0, acc["proj_min"], jnp.nan), "proj_undefined": ep.outer - n}


@dataclass(frozen=True)
class Descriptors:
    """The behaviour descriptors (:mod:`cpgjax.episode.descriptors`): ``duty`` [legs, B] (each leg's duty factor),
    ``heading_speed`` and ``turn`` [B] (forward speed along the heading, m/s, and turning rate, rad/s)."""

    series: ClassVar[bool] = False

    def init(self, ep):
        n_legs = bd.legs(ep.model)[1].shape[0]
        return bd.init(ep.model, ep.s0.x, quat_to_mat(ep.s0.q), n_legs)

    def update(self, ep, acc, smp):
        m = ep.model
        feet = bd.legs(m)[1]
        return bd.update(acc, feet, smp.touching(m), bd.heading(m, smp.R), smp.s.x[:2, m.track]), None

    def finish(self, ep, acc, series, core):
        d = bd.finish(acc, ep.per_sample, ep.per_second)
        return {"duty": d["duty"], "heading_speed": d["speed"], "turn": d["turn"]}


@dataclass(frozen=True)
class Tracking:
    """A steering Schedule's tracking sums (:mod:`cpgjax.episode.steering`), stopped at a fall as the fitness is:
    ``heading_fitness`` and ``turn_error`` [B].  The rollout adds it where the command follows a Schedule."""

    series: ClassVar[bool] = False

    def init(self, ep):
        return st.track_init(*st.heading_of(ep.model, ep.s0))

    def update(self, ep, acc, smp):
        psi, xy = st.heading_of(ep.model, smp.s)
        second = sim_time(ep.model, smp.s) > ep.steer.switch
        return st.track_update(acc, psi, xy, stability(smp.cosu, ep.delta), second, smp.ok & ~smp.was_down), None

    def finish(self, ep, acc, series, core):
        steer = ep.steer
        if ep.length is None:
            hf, err = st.track_finish(acc, ep.T, steer.switch, steer.first, steer.second)
        else:
            hf, err = st.track_finish(acc, None, None, steer.first, steer.second, ep.length)
        return {"heading_fitness": jnp.where(core["diverged"] | ~jnp.isfinite(hf), 0.0, hf), "turn_error": err}
