"""The pure rollout of an episode: `lax.scan` over time with the fitness accumulated online (eq. 4.6).

The scan is nested: an outer loop over log samples (one every 1/LogRate s) and an
inner scan over the integration steps between two samples.  The inner loop carries
only the state and two running sums; the outer loop checks for divergence (a robot
whose state stops being finite or flies off is frozen at its last good sample and
flagged) and, only when asked, records the trajectory.

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

from cpgjax.episode import descriptors as bd
from cpgjax.episode import policy as pol
from cpgjax.episode import sensors
from cpgjax.episode import steering as st
from cpgjax.episode.cpg import targets
from cpgjax.episode.fitness import stability
from cpgjax.episode.support import projection_stability
from cpgjax.sim.contact import terrain_under
from cpgjax.sim.joints import joint_angles
from cpgjax.sim.pipeline import step
from cpgjax.sim.rotation import quat_to_mat
from cpgjax.sim.state import State, initial_state, point_kinematics, sim_time, varied_initial_state

LIMIT_POS = 1.0e3  # m
LIMIT_VEL = 1.0e3  # m/s, rad/s


def schedule(model, time: float | None, log_rate: float | None = None):
    """(steps per sample, samples): the episode is rounded up to whole log periods."""
    T = model.time_max if time is None else float(time)
    rate = model.log_rate if log_rate is None else float(log_rate)
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


def _up_cos(model, q):
    """cos of the angle between the tracked body's normal and the vertical (R_zz)."""
    qb = q[:, model.track]
    return 1.0 - 2.0 * (qb[1] ** 2 + qb[2] ** 2)


# With ``fall_ends``, a robot whose body tilts past this angle has fallen: its fitness stops there.
FALL_TILT = math.radians(60.0)


def probe(model, s: State, R, p, var, delta):
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
    return stability(_up_cos(model, s.q), delta), proj, n_down


def rollout(model, coeffs, *, time=None, delta=8.0, record=False, log_rate=None, forward=1, var=None,
            fall_ends=False, stability_series=False, descriptors=False, latency=0, noise=0.0, length=None):
    """Run B robots with CPG coefficients [n_ctrl, 2K+1, B]; returns a dict of [B] arrays.

    The episode lasts ``time`` s (None: the model's TimeMax), compiled in, or ``length`` (:func:`episode_length`,
    instead of ``time``; traced or not), whose number of log samples is the trip count of a ``while`` loop: one
    program for every length, the same bits.  ``record`` and ``stability_series`` return per-sample arrays, whose
    shape needs the length compiled in: they take ``time`` only.

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
    once its body has tilted past ``FALL_TILT`` (the episode's fitness ends at the fall; it is still
    divided by the whole episode's length); ``down`` says which robots fell so (always False without it)
    and ``up`` the share of the episode before the fall (1 without one).
    With ``record=True`` also ``traj``: x, q [S, ., nb, B], angle, target [S, n, B], t [S], with
    S = samples + 1: t = 0, 1/LogRate, ..., T; for a closed loop also the last step's ``obs`` [S, in, B] (the
    observation it read), its action ``offsets`` [S, n_ctrl, B], ``frequency`` and ``amplitude`` [S, B] and the
    phase offset ``phase`` [S, B] (at t = 0: the first step's).
    With ``stability_series=True`` (thesis Ch. 6.4, :func:`probe`) also, computed in the scan at every
    log sample: ``S`` and ``proj`` [samples, B] (vestibular and projection stability, NaN where the
    latter is undefined), ``S_mean``, ``proj_mean`` (over the defined samples; NaN if none), ``proj_min``
    and ``proj_undefined`` (the number of samples with fewer than three vertices down).
    With ``descriptors=True`` (:mod:`cpgjax.episode.descriptors`, accumulated at every log sample) also
    ``duty`` [legs, B] (each leg's duty factor), ``heading_speed`` and ``turn`` [B] (forward speed along the
    heading, m/s, and turning rate, rad/s).
    A closed loop whose ``steer`` is set (:mod:`cpgjax.episode.steering`) reads a command computed in the scan every
    step (recorded as ``command`` [S, B], and for a ``Course`` the next waypoint's index ``waypoint`` [S, B]); under a
    ``Schedule`` the results add ``heading_fitness`` and ``turn_error`` [B] (the tracking sums, stopped at a fall as
    the fitness is).
    """
    closed = pol.is_closed(coeffs)
    policy = coeffs if closed else None
    steer = policy.steer if closed else None
    schedule_ = isinstance(steer, st.Schedule)
    if closed:
        coeffs = policy.coeffs
        if noise and policy.key is None:
            raise ValueError("sensor noise needs a key per robot (ClosedLoop.key)")
    if length is None:
        inner, outer = schedule(model, time, log_rate)
        T = inner * outer * model.dt
    else:
        if time is not None or record or stability_series:
            raise ValueError("an episode length as data (length=) takes no time=, record= or stability_series=")
        if schedule_:    # its switch and the tracking sums' divisors are data too (steering.switch_length)
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
    s0 = initial_state(model, B, coeffs.dtype) if var is None else varied_initial_state(model, var, coeffs.dtype)
    K, f0, dt = model.harmonics, model.frequency, model.dt
    fwd = forward

    def sense(s, b, command):
        """The observation [in, B] of state ``s`` at the CPG's basis ``b`` (noise added)."""
        phase = (b[1], b[2]) if K else (jnp.zeros((B,), coeffs.dtype),) * 2
        obs = sensors.observe(model, policy.family.inputs, s, var, phase, command, policy.touch)
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
        obs = sense(s, b, command)
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
        if closed:
            cl["d"] = cl["d"] + dt * mf
        vy = s.v[fwd, model.track]
        fit = fit + vy * stability(_up_cos(model, s.q), delta)
        return (s, fit, cl), None

    def outer_body(carry, _):
        s, acc = carry
        if closed:
            acc, cl = acc
        else:
            cl = None
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
        cosu = _up_cos(model, s_new.q)
        down = acc["down"] | (fall_ends & (cosu < math.cos(FALL_TILT)))
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
        out = sample(s_new, R, cl_new) if record else None
        if stability_series:
            S_t, proj_t, _ = probe(model, s_new, R, p, var, delta)
            defined = jnp.isfinite(proj_t)
            acc.update(S=prev["S"] + S_t, proj=prev["proj"] + jnp.where(defined, proj_t, 0.0),
                       proj_n=prev["proj_n"] + defined,
                       proj_min=jnp.minimum(prev["proj_min"], jnp.where(defined, proj_t, jnp.inf)))
            out = (out, {"S": S_t, "proj": proj_t})
        if schedule_:   # the tracking sums (:mod:`cpgjax.episode.steering`)
            psi, xy = st.heading_of(model, s_new)
            second = sim_time(model, s_new) > steer.switch
            acc["track"] = st.track_update(prev["track"], psi, xy, stability(cosu, delta), second, ok & ~prev["down"])
        if descriptors:
            if model.terrain.flat:
                touching = p[2, model.ct_pt] < 0
            else:
                touching = zg - p[2, model.ct_pt] > 0
            acc["bd"] = bd.update(prev["bd"], feet, touching, bd.heading(model, R), s_new.x[:2, model.track])
        return (s_new, (acc, cl_new) if closed else acc), out

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
        _, _, cl0 = closed_ctrl(s0, mem0)
        if latency:   # the first step has no step before: it uses the initial state's observation
            _, _, cl0 = closed_ctrl(s0, cl0)

    z = jnp.zeros((B,), coeffs.dtype)
    acc0 = {"fit": z, "tilt": z, "height": z, "fallen": z < 0, "diverged": z < 0, "pivot_err": z, "depth": z,
            "down": z < 0, "up": z}
    if stability_series:
        acc0.update(S=z, proj=z, proj_n=jnp.zeros((B,), jnp.int32), proj_min=z + jnp.inf)
    if schedule_:
        acc0["track"] = st.track_init(*st.heading_of(model, s0))
    if descriptors:
        feet = bd.legs(model)[1]
        acc0["bd"] = bd.init(model, s0.x, quat_to_mat(s0.q), feet.shape[0])
    carry0 = (s0, (acc0, cl0) if closed else acc0)
    if length is None:
        (s_end, acc), traj = jax.lax.scan(outer_body, carry0, None, length=outer)
    else:   # the samples' count as data: a while loop (a scan where it is concrete), the same body
        s_end, acc = jax.lax.fori_loop(0, outer, lambda i, c: outer_body(c, None)[0], carry0)
    if closed:
        acc, _ = acc
    if stability_series:
        traj, series = traj
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
    if stability_series:
        n = acc["proj_n"]
        res.update(S=series["S"], proj=series["proj"], S_mean=acc["S"] / outer,
                   proj_mean=jnp.where(n > 0, acc["proj"] / jnp.maximum(n, 1), jnp.nan),
                   proj_min=jnp.where(n > 0, acc["proj_min"], jnp.nan), proj_undefined=outer - n)
    if schedule_:
        if length is None:
            hf, err = st.track_finish(acc["track"], T, steer.switch, steer.first, steer.second)
        else:
            hf, err = st.track_finish(acc["track"], None, None, steer.first, steer.second, length)
        res.update(heading_fitness=jnp.where(acc["diverged"] | ~jnp.isfinite(hf), 0.0, hf), turn_error=err)
    if descriptors:
        d = bd.finish(acc["bd"], per_sample, per_second)
        res.update(duty=d["duty"], heading_speed=d["speed"], turn=d["turn"])
    if record:   # the first sample is the initial state, at t = 0
        first = sample(s0, quat_to_mat(s0.q), cl0 if closed else None)
        res["traj"] = jax.tree.map(lambda a0, a: jnp.concatenate([a0[None], a]), first, traj)
    return res
