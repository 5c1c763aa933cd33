"""The pure rollout of an episode: `lax.scan` over time with the fitness accumulated online (eq. 4.6).

The scan is nested: an outer scan over log samples (one every 1/LogRate s) and an
inner scan over the integration steps between two samples.  The inner loop carries
only the state and two running sums; the outer loop checks for divergence (a robot
whose state stops being finite or flies off is frozen at its last good sample and
flagged) and, only when asked, records the trajectory.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

from cpgjax.episode.cpg import targets
from cpgjax.episode.fitness import stability
from cpgjax.sim.joints import joint_angles
from cpgjax.sim.rotation import quat_to_mat
from cpgjax.sim.state import State, initial_state, sim_time, varied_initial_state
from cpgjax.sim.step import point_kinematics, step
from cpgjax.sim.terrain import height_and_normal

LIMIT_POS = 1.0e3  # m
LIMIT_VEL = 1.0e3  # m/s, rad/s


def schedule(model, time: float | None, log_rate: float | None = None):
    """(steps per sample, samples): the episode is rounded up to whole log periods."""
    T = model.time_max if time is None else float(time)
    rate = model.log_rate if log_rate is None else float(log_rate)
    inner = max(1, int(round(1.0 / (rate * model.dt))))
    outer = max(1, int(math.ceil(round(T / model.dt, 6) / inner)))
    return inner, outer


def _healthy(s: State):
    ok = jnp.all(jnp.isfinite(s.x), axis=(0, 1)) & jnp.all(jnp.isfinite(s.v), axis=(0, 1))
    ok &= jnp.all(jnp.isfinite(s.w), axis=(0, 1)) & jnp.all(jnp.isfinite(s.q), axis=(0, 1))
    ok &= jnp.all(jnp.abs(s.x) < LIMIT_POS, axis=(0, 1)) & jnp.all(jnp.abs(s.v) < LIMIT_VEL, axis=(0, 1))
    ok &= jnp.all(jnp.abs(s.w) < 10 * LIMIT_VEL, axis=(0, 1))
    return ok


def _keep(ok, new, old):
    return jax.tree.map(lambda n, o: jnp.where(ok, n, o) if n.ndim else n, new, old)


def _up_cos(model, q):
    """cos of the angle between the tracked body's normal and the vertical (R_zz)."""
    qb = q[:, model.track]
    return 1.0 - 2.0 * (qb[1] ** 2 + qb[2] ** 2)


# With ``fall_ends``, a robot whose body tilts past this angle has fallen: its fitness stops there.
FALL_TILT = math.radians(60.0)


def rollout(model, coeffs, *, time=None, delta=8.0, record=False, log_rate=None, forward=1, var=None,
            fall_ends=False):
    """Run B robots with CPG coefficients [n_ctrl, 2K+1, B]; returns a dict of [B] arrays.

    Keys: fitness (eq. 4.6, mean of eq. 4.5), distance (forward, m), speed (distance/T),
    tilt (mean body angle from vertical, rad), fallen (body normal ever pointed down),
    diverged, pivot_err (max pivot-spring stretch at the samples, m), depth (max contact
    depth at the samples, m), height (mean CM height of the tracked body, m).
    ``var``: a per-robot :class:`~cpgjax.sim.variation.Variation` (initial pose, masses, friction, gains,
    terrain shift); ``None`` is the nominal robot.  ``fall_ends``: a robot's fitness stops accumulating
    once its body has tilted past ``FALL_TILT`` (the episode's fitness ends at the fall; it is still
    divided by the whole episode's length).
    With ``record=True`` also ``traj``: x, q [S, ., nb, B], angle, target [S, n, B], t [S], with
    S = samples + 1: t = 0, 1/LogRate, ..., T.
    """
    inner, outer = schedule(model, time, log_rate)
    T = inner * outer * model.dt
    B = coeffs.shape[-1]
    s0 = initial_state(model, B, coeffs.dtype) if var is None else varied_initial_state(model, var, coeffs.dtype)
    K, f0, dt = model.harmonics, model.frequency, model.dt
    fwd = forward

    def inner_body(carry, _):
        s, fit = carry
        ctrl = targets(coeffs, sim_time(model, s), K, f0)
        s = step(model, s, ctrl, var)
        vy = s.v[fwd, model.track]
        fit = fit + vy * stability(_up_cos(model, s.q), delta)
        return (s, fit), None

    def outer_body(carry, _):
        s, acc = carry
        zero = jnp.zeros((B,), coeffs.dtype)
        (s_new, fit), _ = jax.lax.scan(inner_body, (s, zero), None, length=inner)
        ok = _healthy(s_new) & ~acc["diverged"]
        s_new = _keep(ok, s_new, s)
        R = quat_to_mat(s_new.q)
        _, p, _ = point_kinematics(model, s_new, R)
        zero = jnp.zeros((B,), coeffs.dtype)
        piv = jnp.sqrt(jnp.sum((p[:, model.sp_b] - p[:, model.sp_a]) ** 2, 0)).max(0, initial=0.0)
        if model.terrain.flat:
            depth = (-p[2, model.ct_pt]).max(0, initial=0.0)
        else:
            sx, sy = (0.0, 0.0) if var is None else (var.shift[0], var.shift[1])
            zg, _ = height_and_normal(model.terrain, p[0, model.ct_pt] + sx, p[1, model.ct_pt] + sy)
            depth = (zg - p[2, model.ct_pt]).max(0, initial=0.0) + zero
        cosu = _up_cos(model, s_new.q)
        acc = {
            "fit": acc["fit"] + jnp.where(ok & ~acc["down"], fit, 0.0),
            "down": acc["down"] | (fall_ends & (cosu < math.cos(FALL_TILT))),
            "tilt": acc["tilt"] + jnp.arccos(jnp.clip(cosu, -1.0, 1.0)),
            "height": acc["height"] + s_new.x[2, model.track],
            "fallen": acc["fallen"] | (cosu < 0),
            "diverged": acc["diverged"] | ~ok,
            "pivot_err": jnp.maximum(acc["pivot_err"], jnp.where(ok, piv, 0.0)),
            "depth": jnp.maximum(acc["depth"], jnp.where(ok, depth, 0.0)),
        }
        return (s_new, acc), (sample(s_new, R) if record else None)

    def sample(s, R):
        angle, _, _ = joint_angles(model, R, s.w)
        t = sim_time(model, s)
        tgt, _ = targets(coeffs, t, K, f0)
        return {"x": s.x, "q": s.q, "v": s.v, "w": s.w, "angle": angle, "target": tgt, "t": t}

    z = jnp.zeros((B,), coeffs.dtype)
    acc0 = {"fit": z, "tilt": z, "height": z, "fallen": z < 0, "diverged": z < 0, "pivot_err": z, "depth": z,
            "down": z < 0}
    (s_end, acc), traj = jax.lax.scan(outer_body, (s0, acc0), None, length=outer)
    dist = s_end.x[fwd, model.track] - s0.x[fwd, model.track]
    fitness = acc["fit"] * dt / T
    res = {
        "fitness": jnp.where(acc["diverged"] | ~jnp.isfinite(fitness), 0.0, fitness),
        "distance": dist,
        "speed": dist / T,
        "tilt": acc["tilt"] / outer,
        "height": acc["height"] / outer,
        "fallen": acc["fallen"],
        "diverged": acc["diverged"],
        "pivot_err": acc["pivot_err"],
        "depth": acc["depth"],
    }
    if record:   # the first sample is the initial state, at t = 0
        res["traj"] = jax.tree.map(lambda a0, a: jnp.concatenate([a0[None], a]), sample(s0, quat_to_mat(s0.q)), traj)
    return res
