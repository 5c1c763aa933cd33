"""The pure rollout of an episode: `lax.scan` over time with the fitness accumulated online (eq. 4.6).

The scan is nested: an outer loop over log samples (one every 1/LogRate s) and an
inner scan over the integration steps between two samples.  The inner loop carries
only the state and two running sums; the outer loop checks for divergence (a robot
whose state stops being finite or flies off is frozen at its last good sample and
flagged) and updates the probes the caller passed (:mod:`cpgjax.episode.probes`: the trajectory, stability,
behaviour descriptors, a steering schedule's tracking).

The inner scan's length (steps per log period) depends on the model alone.  The number of log samples is
either compiled in (``time``: a static scan) or data (``length``, :func:`episode_length`: a ``while`` loop whose
trip count is a traced argument), so that one compiled program serves every episode length of a model and batch
width; the scores are the same bits either way (tests/episode/test_rollout.py).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.episode import policy as pol
from cpgjax.episode import probes as pb
from cpgjax.episode import sensors
from cpgjax.episode import steering as st
from cpgjax.episode.cpg import targets
from cpgjax.episode.fitness import stability, up_cos
from cpgjax.sim.contact import terrain_under
from cpgjax.sim.joints import joint_angles
from cpgjax.sim.pipeline import init, step
from cpgjax.sim.rotation import quat_to_mat
from cpgjax.sim.state import State, point_kinematics, sim_time

LIMIT_POS = 1.0e3  # m
LIMIT_VEL = 1.0e3  # m/s, rad/s


def schedule(model, time: float | None, log_rate: float | None = None):
    """(steps per sample, samples): the episode is rounded up to whole log periods."""
    T = model.episode.time_max if time is None else float(time)
    rate = model.episode.log_rate if log_rate is None else float(log_rate)
    inner = max(1, int(round(1.0 / (rate * model.dt))))
    outer = max(1, int(math.ceil(round(T / model.dt, 6) / inner)))
    return inner, outer


def episode_length(model, time: float | None, log_rate: float | None = None, switch: float | None = None) -> dict:
    """The episode's length as data for :func:`rollout`'s ``length``: ``{"samples": int32, "per_sample": float32,
    "per_second": float32}`` (numpy scalars): the log samples (:func:`schedule`'s rounding), 1/samples and 1/T; with
    a steering schedule's ``switch`` (s) also its entries (:func:`cpgjax.episode.steering.switch_length`).

    Why reciprocals: XLA turns a division by a constant into a product with the constant's float32 reciprocal
    (folded with the constants it multiplies), a division by an argument it does not; a product with these
    reciprocals, rounded on the host as XLA rounds them, gives the bits of the length compiled in.
    """
    inner, outer = schedule(model, time, log_rate)
    one, T = np.float32(1.0), inner * outer * model.dt
    out = {"samples": np.int32(outer), "per_sample": one / np.float32(outer), "per_second": one / np.float32(T)}
    return out if switch is None else out | st.switch_length(switch, T)


def _healthy(s: State):
    ok = jnp.all(jnp.isfinite(s.x), axis=(0, 1)) & jnp.all(jnp.isfinite(s.v), axis=(0, 1))
    ok &= jnp.all(jnp.isfinite(s.w), axis=(0, 1)) & jnp.all(jnp.isfinite(s.q), axis=(0, 1))
    ok &= jnp.all(jnp.abs(s.x) < LIMIT_POS, axis=(0, 1)) & jnp.all(jnp.abs(s.v) < LIMIT_VEL, axis=(0, 1))
    ok &= jnp.all(jnp.abs(s.w) < 10 * LIMIT_VEL, axis=(0, 1))
    return ok


def _keep(ok, new, old):
    return jax.tree.map(lambda n, o: jnp.where(ok, n, o) if n.ndim else n, new, old)


# With ``fall_ends``, a robot whose body tilts past this angle has fallen: its fitness stops there.
FALL_TILT = math.radians(60.0)


def rollout(model, coeffs, *, time=None, delta=8.0, probes=(), log_rate=None, forward=1, var=None,
            fall_ends=False, fall_tilt=FALL_TILT, latency=0, noise=0.0, length=None):
    """Run B robots with CPG coefficients [n_ctrl, 2K+1, B]; returns a dict of [B] arrays.

    The episode lasts ``time`` s (None: the model's TimeMax), compiled in, or ``length`` (:func:`episode_length`,
    instead of ``time``; traced or not), whose number of log samples is the trip count of a ``while`` loop: one
    program for every length, the same bits.

    ``probes`` (:mod:`cpgjax.episode.probes`): what the scan measures beside the keys below, each probe's results
    added to them: :class:`~cpgjax.episode.probes.Record` the trajectory, ``Stability`` thesis Ch. 6.4's measures
    at every sample, ``Descriptors`` the repertoire's behaviour descriptors.  A probe with per-sample arrays
    (``Record``, ``Stability``) needs the length compiled in: ``time``, not ``length``.

    ``coeffs`` may instead be a batch-last :class:`~cpgjax.episode.policy.ClosedLoop` (the CPG modulated by a
    policy that reads the robot's sensors every step, :mod:`cpgjax.episode.policy`); its CPG phase offset is
    integrated in the scan.  ``latency`` (0 or 1 step): its action uses the observation of the step before;
    ``noise``: sensor noise of that many of each sensor's scale (standard deviation), drawn per robot and step from
    the controller's ``key`` (:func:`cpgjax.episode.sensors.noise`).

    Keys: fitness (eq. 4.6, mean of eq. 4.5), distance (forward, m), speed (distance/T),
    tilt (mean body angle from vertical, rad), fallen (body normal ever pointed down),
    diverged, pivot_err (max pivot-spring stretch at the samples, m), depth (max contact
    depth at the samples, m), height (mean CM height of the tracked body, m).
    ``var``: a per-robot :class:`~cpgjax.sim.variation.Variation` (initial pose, masses, friction, gains,
    terrain shift); ``None`` is the nominal robot.  ``fall_ends``: a robot's fitness stops accumulating
    once its body has tilted past ``fall_tilt`` (rad; ``FALL_TILT``, 60 degrees, unless the robust evaluation's
    ``fall_tilt`` sets a margin below it) (the episode's fitness ends at the fall; it is still
    divided by the whole episode's length); ``down`` says which robots fell so (always False without it)
    and ``up`` the share of the episode before the fall (1 without one).
    ``Record``'s ``traj``: x, q [S, ., nb, B], angle, target [S, n, B], t [S], with
    S = samples + 1: t = 0, 1/LogRate, ..., T; for a closed loop also the last step's ``obs`` [S, in, B] (the
    observation it read), its action ``offsets`` [S, n_ctrl, B], ``frequency`` and ``amplitude`` [S, B] and the
    phase offset ``phase`` [S, B] (at t = 0: the first step's).
    A closed loop whose ``steer`` is set (:mod:`cpgjax.episode.steering`) reads a command computed in the scan every
    step (recorded as ``command`` [S, B], and for a ``Course`` the next waypoint's index ``waypoint`` [S, B]); under a
    ``Schedule`` the rollout adds the probe :class:`~cpgjax.episode.probes.Tracking` (``heading_fitness`` and
    ``turn_error`` [B]).
    """
    closed = pol.is_closed(coeffs)
    policy = coeffs if closed else None
    steer = policy.steer if closed else None
    probes = tuple(probes) + ((pb.Tracking(),) if isinstance(steer, st.Schedule) else ())
    if closed:
        coeffs = policy.coeffs
        if noise and policy.key is None:
            raise ValueError("sensor noise needs a key per robot (ClosedLoop.key)")
    if length is None:
        inner, outer = schedule(model, time, log_rate)
        T = inner * outer * model.dt
    else:
        if time is not None or any(pr.series for pr in probes):
            raise ValueError("an episode length as data (length=) takes no time= and no probe with per-sample "
                             "arrays (Record, Stability)")
        if isinstance(steer, st.Schedule):   # its switch and the tracking sums' divisors: data (steering.switch_length)
            if steer.switch is not None or "switch" not in length:
                raise ValueError("with length=, a steering Schedule's switch is the length's (switch=None, "
                                 "steering.switch_length)")
            steer = steer.at(length["switch"])
        inner = schedule(model, None, log_rate)[0]     # the steps per log period: the model's dt and log rate alone
        outer = length["samples"]

    def per_sample(a):   # a sum over the samples, over their number
        return a / outer if length is None else a * length["per_sample"]

    def per_second(a):   # a sum over the episode's seconds
        return a / T if length is None else a * length["per_second"]

    B = coeffs.shape[-1]
    s0 = init(model, B, var, coeffs.dtype)
    shove = None
    if var is not None and var.push is not None:   # (velocity [3, B], the step after which it is added [B])
        steps = outer * inner
        shove = (var.push.astype(coeffs.dtype), jnp.floor(var.push_at * steps).astype(jnp.int32) + 1)
    K, f0, dt = model.episode.harmonics, model.episode.frequency, model.dt
    fwd = forward

    def sense(s, b, command, stance=None):
        """The observation [in, B] of state ``s`` at the CPG's basis ``b`` (noise added)."""
        phase = (b[1], b[2]) if K else (jnp.zeros((B,), coeffs.dtype),) * 2
        obs = sensors.observe(model, policy.family.inputs, s, var, phase, command, policy.touch, stance)
        if noise:
            amp = noise * sensors.noise_scale(model, policy.family.inputs)
            # kept apart from the sum (cf. episode.perturb._one): the same bits in every program
            obs = obs + jax.lax.optimization_barrier(sensors.noise(policy.key, s.n, amp))
        return obs

    def closed_ctrl(s, cl):
        """The servo targets of the closed loop at ``s``, the action's frequency modulation and the new memory."""
        b, db = pol.phase_basis(sim_time(model, s), cl["d"], K, f0)
        mem = {}
        if steer is None:
            command = policy.command
        else:   # the command computed from the state (:mod:`cpgjax.episode.steering`)
            command, smem = steer.command(model, s, cl["steer"])
            mem = {"steer": smem, "command": command}
        stance = None
        if "stance" in policy.family.inputs:   # the touch sensors low-passed, step by step
            stance = sensors.stance_update(model, cl["stance"], sensors.touch(model, s, var, policy.touch))
            mem["stance"] = stance
        obs = sense(s, b, command, stance)
        off, mf, ma = pol.act(policy.family, model, policy.weights, cl["obs"] if latency else obs)
        ctrl = pol.modulated_targets(coeffs, b, db, off, mf, ma)
        return ctrl, mf, {"d": cl["d"], "obs": obs, "target": ctrl[0], "action": (off, mf, ma)} | mem

    def inner_body(carry, _):
        s, fit, cl = carry
        if closed:
            ctrl, mf, cl = closed_ctrl(s, cl)
        else:
            ctrl = targets(coeffs, sim_time(model, s), K, f0)
        s = step(model, s, ctrl, var)
        if shove is not None:   # the episode's shove (perturb ``push``): a velocity added to every body, once
            s = s._replace(v=s.v + jnp.where(s.n == shove[1], 1.0, 0.0)[None, None] * shove[0][:, None])
        if closed:
            cl["d"] = cl["d"] + dt * mf
        vy = s.v[fwd, model.track]
        fit = fit + vy * stability(up_cos(model, s.q), delta)
        return (s, fit, cl), None

    def outer_body(carry, _):
        s, acc = carry
        if closed:
            acc, cl = acc
        else:
            cl = None
        acc, pacc_prev = acc
        prev = acc
        zero = jnp.zeros((B,), coeffs.dtype)
        (s_new, fit, cl_new), _ = jax.lax.scan(inner_body, (s, zero, cl), None, length=inner)
        ok = _healthy(s_new) & ~acc["diverged"]
        s_new = _keep(ok, s_new, s)
        if closed:
            cl_new = _keep(ok, cl_new, cl)
        R = quat_to_mat(s_new.q)
        _, p, _ = point_kinematics(model, s_new, R)
        zero = jnp.zeros((B,), coeffs.dtype)
        piv = jnp.sqrt(jnp.sum((p[:, model.sp_b] - p[:, model.sp_a]) ** 2, 0)).max(0, initial=0.0)
        if model.terrain.flat:
            depth = (-p[2, model.ct_pt]).max(0, initial=0.0)
        else:
            zg, _ = terrain_under(model, p[0, model.ct_pt], p[1, model.ct_pt], var)
            depth = (zg - p[2, model.ct_pt]).max(0, initial=0.0) + zero
        cosu = up_cos(model, s_new.q)
        down = acc["down"] | (fall_ends & (cosu < math.cos(fall_tilt)))
        acc = {
            "fit": acc["fit"] + jnp.where(ok & ~acc["down"], fit, 0.0),
            "up": acc["up"] + jnp.where(down, 0.0, 1.0),     # the log samples at which it is still up
            "down": down,
            "tilt": acc["tilt"] + jnp.arccos(jnp.clip(cosu, -1.0, 1.0)),
            "height": acc["height"] + s_new.x[2, model.track],
            "fallen": acc["fallen"] | (cosu < 0),
            "diverged": acc["diverged"] | ~ok,
            "pivot_err": jnp.maximum(acc["pivot_err"], jnp.where(ok, piv, 0.0)),
            "depth": jnp.maximum(acc["depth"], jnp.where(ok, depth, 0.0)),
        }
        smp = pb.Sample(s_new, R, p, None if model.terrain.flat else zg, cosu, ok, prev["down"], cl_new)
        paccs, outs = [], []
        for pr, pacc in zip(probes, pacc_prev, strict=True):
            pacc, o = pr.update(ep, pacc, smp)
            paccs.append(pacc)
            outs.append(o)
        return (s_new, ((acc, tuple(paccs)), cl_new) if closed else (acc, tuple(paccs))), tuple(outs)

    def sample(s, R, cl=None):
        angle, _, _ = joint_angles(model, R, s.w)
        t = sim_time(model, s)
        if not closed:
            tgt, _ = targets(coeffs, t, K, f0)
            return {"x": s.x, "q": s.q, "v": s.v, "w": s.w, "angle": angle, "target": tgt, "t": t}
        # the closed loop: the target, observation and action of the sample's last step (at t = 0: the first step's)
        off, mf, ma = cl["action"]
        out = {"x": s.x, "q": s.q, "v": s.v, "w": s.w, "angle": angle, "target": cl["target"], "t": t,
               "obs": cl["obs"], "offsets": off, "frequency": mf, "amplitude": ma, "phase": cl["d"]}
        if steer is not None:
            out["command"] = cl["command"]
            out.update(cl["steer"])
        return out

    if closed:   # the memory of the loop: the phase offset d, the last observation, target and action
        mem0 = {"d": jnp.zeros((B,), coeffs.dtype), "obs": jnp.zeros((policy.family.n_in(model), B), coeffs.dtype)}
        if steer is not None:
            mem0["steer"] = steer.init(model, s0)
        if "stance" in policy.family.inputs:   # from the first reading on
            mem0["stance"] = sensors.touch(model, s0, var, policy.touch)
        _, _, cl0 = closed_ctrl(s0, mem0)
        if latency:   # the first step has no step before: it uses the initial state's observation
            _, _, cl0 = closed_ctrl(s0, cl0)

    else:
        cl0 = None
    ep = pb.Episode(model, s0, var, delta, steer, sample, cl0, outer, per_sample, per_second,
                    T if length is None else None, length)

    z = jnp.zeros((B,), coeffs.dtype)
    acc0 = {"fit": z, "tilt": z, "height": z, "fallen": z < 0, "diverged": z < 0, "pivot_err": z, "depth": z,
            "down": z < 0, "up": z}
    acc0 = (acc0, tuple(pr.init(ep) for pr in probes))
    carry0 = (s0, (acc0, cl0) if closed else acc0)
    if length is None:
        (s_end, acc), series = jax.lax.scan(outer_body, carry0, None, length=outer)
    else:   # the samples' count as data: a while loop (a scan where it is concrete), the same body
        s_end, acc = jax.lax.fori_loop(0, outer, lambda i, c: outer_body(c, None)[0], carry0)
        series = (None,) * len(probes)
    if closed:
        acc, _ = acc
    acc, paccs = acc
    dist = s_end.x[fwd, model.track] - s0.x[fwd, model.track]
    fitness = per_second(acc["fit"] * dt)
    res = {
        "fitness": jnp.where(acc["diverged"] | ~jnp.isfinite(fitness), 0.0, fitness),
        "distance": dist,
        "speed": per_second(dist),
        "tilt": per_sample(acc["tilt"]),
        "height": per_sample(acc["height"]),
        "fallen": acc["fallen"],
        "down": acc["down"],
        "up": per_sample(acc["up"]),
        "diverged": acc["diverged"],
        "pivot_err": acc["pivot_err"],
        "depth": acc["depth"],
    }
    for pr, pacc, ser in zip(probes, paccs, series, strict=True):
        res.update(pr.finish(ep, pacc, ser, acc))
    return res
