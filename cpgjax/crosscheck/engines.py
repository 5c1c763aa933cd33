"""The same controllers in MuJoCo (C, native batched rollout) and MJX.

The CPG is a function of time only, so an open-loop controller is a precomputed control sequence:
``u(t) = q*(t) + (kd/kp) q*'(t)`` per position actuator (this makes MuJoCo's
``kp (u - q) - kv qdot`` equal to our servo's ``kp (q* - q) + kd (q*' - qdot)``).
Metrics are computed exactly as the penalty simulator does (eq. 4.5-4.6) from the
tracked body's CM and orientation; the tracked body must be a root body (free joint).
A closed-loop controller (:mod:`cpgjax.episode.policy`) reads its sensors from MuJoCo's state every step
(:func:`mujoco_observe`, :func:`mujoco_closed_run`; MuJoCo C only).
"""

from __future__ import annotations

import contextlib
import contextvars
import time as _time

import numpy as np

from cpgjax.crosscheck.impedance import from_rest, step, stepper
from cpgjax.crosscheck.mjcf import MJ_TIMESTEP, initial_qpos, load
from cpgjax.episode.cpg import basis
from cpgjax.episode.fitness import DEFAULT_DELTA
from cpgjax.sim.rotation import quat_to_mat_np


def controls(model, coeffs, nstep: int, dt: float) -> np.ndarray:
    """[N, nstep, nu] actuator inputs for CPG coefficients [N, n_ctrl, 2K+1]."""
    import jax.numpy as jnp

    t = np.arange(nstep) * dt
    ep = model.episode
    b, db = (np.asarray(x) for x in basis(jnp.asarray(t, jnp.float32), ep.harmonics, ep.frequency))
    c = np.asarray(coeffs, np.float64)
    q = np.einsum("nck,ks->nsc", c, b)
    dq = np.einsum("nck,ks->nsc", c, db)
    cj = model.ctrl_joint
    ratio = np.where(model.j_kp[cj] > 0, model.j_kd[cj] / np.maximum(model.j_kp[cj], 1e-12), 0.0)
    return q + ratio[None, None, :] * dq


def root_slice(model, mj):
    """Where the tracked body's free joint sits in MuJoCo's ``qpos``: its 7 entries (position, quaternion) as a
    slice; a tracked body that is not a free root body is a ``ValueError``."""
    import mujoco

    bid = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, model.body_names[model.track])
    jid = mj.body_jntadr[bid]
    if jid < 0 or mj.jnt_type[jid] != mujoco.mjtJoint.mjJNT_FREE:
        raise ValueError(f"the tracked body {model.body_names[model.track]!r} must be a free root body")
    a = mj.jnt_qposadr[jid]
    return slice(a, a + 7)


def metrics_from_qpos(model, mj, qpos: np.ndarray, dt: float, delta: float = DEFAULT_DELTA) -> dict:
    """Fitness, distance, speed, tilt, fallen from qpos trajectories [N, S, nq] sampled every dt."""
    from cpgjax.episode.fitness import stability

    root = qpos[..., root_slice(model, mj)]
    pos, quat = root[..., :3], root[..., 3:]
    R = quat_to_mat_np(np.moveaxis(quat, -1, 0))  # [3, 3, N, S]
    cm = pos + np.einsum("ijns,j->nsi", R, model.cm_local[:, model.track])
    up = R[2, 2]
    vy = np.diff(cm[..., 1], axis=-1) / dt
    s = np.asarray(stability(up[..., 1:], delta))
    T = dt * (qpos.shape[1] - 1)
    dist = cm[:, -1, 1] - cm[:, 0, 1]
    ok = np.isfinite(qpos).all(axis=(1, 2))
    return {
        "fitness": np.where(ok, (vy * s).mean(-1), 0.0), "distance": np.where(ok, dist, 0.0),
        "speed": np.where(ok, dist / T, 0.0), "tilt": np.arccos(np.clip(up, -1, 1)).mean(-1),
        "fallen": (up < 0).any(-1), "diverged": ~ok, "cm": cm,
    }


def joint_angles(model, mj, qpos):
    """[N, S, nj] hinge angles in the order of the `.wl` joints."""
    import mujoco

    adr = [mj.jnt_qposadr[mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_JOINT, n)] for n in model.joint_names]
    return qpos[..., adr]


def _rollout_from_rest(model, mj, ctrl: np.ndarray, nthread: int | None):
    """(x0, states [N, nstep, ...]): MuJoCo C's threaded rollout of controls [N, nstep, nu] from the initial pose."""
    import os

    import mujoco
    from mujoco import rollout

    d = mujoco.MjData(mj)
    d.qpos[:] = initial_qpos(model, mj)
    mujoco.mj_forward(mj, d)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    x0 = np.zeros(mujoco.mj_stateSize(mj, spec))
    mujoco.mj_getState(mj, d, x0, spec)
    nthread = nthread or os.cpu_count() or 1
    with rollout.Rollout(nthread=nthread) as r:
        state, _ = r.rollout(mj, [mujoco.MjData(mj) for _ in range(nthread)], x0[None], ctrl)
    return x0, state


def mujoco_run(model, coeffs, *, time: float, delta: float = DEFAULT_DELTA, timestep: float = MJ_TIMESTEP,
               nthread: int | None = None, mj=None):
    """Roll out N controllers in MuJoCo C (native threaded rollout). Returns metrics, qpos [N, S, nq], wall.

    Closed-loop controllers (a :class:`~cpgjax.episode.policy.ClosedLoop`) run step by step with their policy
    (:func:`mujoco_closed_run`)."""
    from cpgjax.episode.policy import is_closed

    if is_closed(coeffs):
        return mujoco_closed_run(model, coeffs, time=time, delta=delta, timestep=timestep, mj=mj)
    mj = mj if mj is not None else load(model, timestep=timestep)
    nstep = int(round(time / mj.opt.timestep))
    ctrl = controls(model, coeffs, nstep, mj.opt.timestep)
    t0 = _time.perf_counter()
    law = stepper(model, mj, len(ctrl))
    if law is None:
        x0, state = _rollout_from_rest(model, mj, ctrl, nthread)
        qpos = np.concatenate([np.repeat(x0[None, None, 1:1 + mj.nq], len(ctrl), 0), state[..., 1:1 + mj.nq]], 1)
    else:      # eq. 3.7's force per contact (crosscheck.impedance): the model changes between steps, one robot a time
        qpos = np.zeros((len(ctrl), nstep + 1, mj.nq))
        for i, u in enumerate(ctrl):
            d = from_rest(model, mj, law, i)
            qpos[i, 0] = d.qpos
            for s in range(nstep):
                d.ctrl[:] = u[s]
                step(mj, d, law, i)
                qpos[i, s + 1] = d.qpos
    wall = _time.perf_counter() - t0
    return _metrics(model, mj, qpos, mj.opt.timestep, delta), qpos, wall


def _metrics(model, mj, qpos, dt, delta):
    try:
        return metrics_from_qpos(model, mj, qpos, dt, delta)
    except ValueError:  # the tracked body is fixed or jointed (a test rig): no walking metrics
        return {"diverged": ~np.isfinite(qpos).all(axis=(1, 2))}


def fast_mjx_options(mj, iterations: int = 2, ls_iterations: int = 2):
    """MJX's fastest CPU settings that still agree with MuJoCo C (docs/crosscheck.md).

    Fewer solver and line-search iterations; the integrator stays ``implicitfast`` (the
    explicit Euler integrator, with or without Euler damping, disagreed: a standing robot
    crept forward 0.24 m in 3 s, rank correlation with MuJoCo C -0.17 on 8 controllers).
    """
    mj.opt.iterations = iterations
    mj.opt.ls_iterations = ls_iterations
    return mj


def mjx_run(model, coeffs, *, time: float, delta: float = DEFAULT_DELTA, timestep: float = MJ_TIMESTEP,
            fast: bool = True, sample_every: int = 1, chunk: int = 64):
    """Roll out N controllers in MJX (vmapped over chunks of the batch, `lax.scan` over time).

    Chunks of ``chunk`` robots run one after the other through one compiled program: on this
    CPU a vmapped batch of 256 did not finish compiling and running within 4 minutes, while
    64 and 128 ran in seconds.  Returns (metrics, qpos [N, S, nq], compile_s, run_s): compile_s the
    ahead-of-time ``lower().compile()`` of the program, run_s every chunk through it."""
    import jax
    import jax.numpy as jnp
    from mujoco import mjx

    mj = load(model, timestep=timestep, ground="hfield")    # MJX keeps the heightfield (mesh and boxes: C only)
    if fast:
        fast_mjx_options(mj)
    mx = mjx.put_model(mj)
    nstep = int(round(time / mj.opt.timestep))
    ctrl = jnp.asarray(controls(model, coeffs, nstep, mj.opt.timestep), jnp.float32)
    q0 = jnp.asarray(initial_qpos(model, mj), jnp.float32)

    def one(u):
        d = mjx.make_data(mx).replace(qpos=q0)

        def body(d, uk):
            d = mjx.step(mx, d.replace(ctrl=uk))
            return d, d.qpos

        _, qs = jax.lax.scan(body, d, u)
        return qs[::sample_every]

    f = jax.jit(jax.vmap(one))
    n = ctrl.shape[0]
    ch = min(chunk, n)
    pad = -(-n // ch) * ch - n
    if pad:
        ctrl = jnp.concatenate([ctrl, jnp.repeat(ctrl[-1:], pad, 0)])
    # compile time: the ahead-of-time compile of the one program, timed alone (never negative: no
    # difference of two timed calls); the run: every chunk through that compiled program
    t0 = _time.perf_counter()
    compiled = f.lower(ctrl[:ch]).compile()
    comp = _time.perf_counter() - t0
    t0 = _time.perf_counter()
    qs = jnp.concatenate([jax.block_until_ready(compiled(ctrl[k:k + ch])) for k in range(0, n + pad, ch)])[:n]
    run = _time.perf_counter() - t0
    qpos = np.concatenate([np.repeat(np.asarray(q0)[None, None], len(ctrl), 0), np.asarray(qs, np.float64)], 1)
    return _metrics(model, mj, qpos, mj.opt.timestep * sample_every, delta), qpos, comp, run


def mujoco_track(model, freq, amp, *, center=None, time: float, settle: float, ctrl: int = 0,
                 timestep: float | None = None, record: bool = False, nthread: int | None = None) -> dict:
    """The servo experiment of `cpgjax.episode.tracking.tracking_rollout` in MuJoCo C, on the exported rig.

    Same drive ``center + amp sin(2 pi freq t)`` on controlled joint ``ctrl`` (others held at
    ``center``), same error window, same statistics (``err``, ``ref``, ``rel`` [B]); the step is
    the penalty model's ``dt`` unless ``timestep`` is given.
    """


    from cpgjax.episode.tracking import window_start

    mj = load(model, timestep=timestep or model.dt)
    dt = mj.opt.timestep
    nstep = int(round(time / dt))
    f = np.asarray(freq, float)[:, None]
    a = np.asarray(amp, float)[:, None]
    t = np.arange(nstep) * dt                       # control at the start of each step
    cj = model.ctrl_joint
    c = np.asarray(model.j_q0[cj] if center is None else center, float)
    ratio = np.where(model.j_kp[cj] > 0, model.j_kd[cj] / np.maximum(model.j_kp[cj], 1e-12), 0.0)
    u = np.repeat(np.repeat(c[None, None], len(f), 0), nstep, 1)
    w = 2 * np.pi * f
    u[:, :, ctrl] = c[ctrl] + a * np.sin(w * t) + ratio[ctrl] * a * w * np.cos(w * t)
    _, state = _rollout_from_rest(model, mj, u, nthread)
    angle = joint_angles(model, mj, state[..., 1:1 + mj.nq])[..., int(cj[ctrl])]   # [B, nstep] after each step
    t1 = (np.arange(nstep) + 1) * dt
    target = c[ctrl] + a * np.sin(w * t1)
    m = t1[None] > window_start(f[:, 0], nstep * dt, settle)[:, None] + 0.5 * dt
    e = (np.abs(target - angle) * m).sum(1)
    ref = (np.abs(target - c[ctrl]) * m).sum(1)
    out = {"err": e / m.sum(1), "ref": ref / m.sum(1), "rel": e / np.maximum(ref, 1e-30)}
    if record:
        out.update(angle=angle.T, target=target.T, t=t1)
    return out


def foot_geoms(model, mj) -> np.ndarray:
    """[ngeom] the leg (``episode.descriptors.legs`` order) of each exported contact sphere of a foot, else -1."""
    import mujoco

    from cpgjax.episode.descriptors import legs

    feet = legs(model)[1]
    leg_of = np.full(mj.ngeom, -1)
    for k, pt in enumerate(model.ct_pt):
        hit = np.nonzero(feet[:, k])[0]
        if len(hit):
            name = f"{model.body_names[model.pt_body[pt]]}_c{k}"
            gid = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_GEOM, name)
            if gid < 0:
                raise ValueError(f"the exported model has no contact sphere {name!r} (crosscheck.mjcf)")
            leg_of[gid] = hit[0]
    return leg_of


def mujoco_touch(mj, datas, leg_of) -> np.ndarray:
    """[N, legs] the touch sensors in MuJoCo C: 1 where a leg's foot sphere has a contact at distance <= 0."""
    c = np.zeros((len(datas), int(leg_of.max()) + 1 if (leg_of >= 0).any() else 0))
    for n, d in enumerate(datas):
        for i in range(d.ncon):
            con = d.contact[i]
            if con.dist <= 0:
                for g in (con.geom1, con.geom2):
                    if leg_of[g] >= 0:
                        c[n, leg_of[g]] = 1.0
    return c


def mujoco_observe(model, mj, datas, groups, phase, command, leg_of=None, stance=None) -> np.ndarray:
    """[N, n] the observation of a closed-loop controller (:mod:`cpgjax.episode.sensors`) from MuJoCo's state.

    The same readings as ours, each from MuJoCo's own state: the hinges' ``qpos``; roll and pitch from the tracked
    body's orientation (``qpos`` of its free joint) and their rates from its angular velocity (MuJoCo's free joint
    gives it in the body's frame); a foot touches when MuJoCo has a contact of one of its spheres (its distance to
    the ground <= 0: the sphere's surface on or in the ground, where ours tests the vertex, its centre).
    ``phase`` (sin, cos) [N] and ``command`` [N] as ours; ``stance`` [N, legs] the low-passed touch reading
    (:func:`cpgjax.episode.sensors.stance_update`, kept by the caller), None: the touch sensors' reading.
    """
    from cpgjax.episode import sensors

    leg_of = foot_geoms(model, mj) if leg_of is None else leg_of
    root = root_slice(model, mj)
    parts = {g: [] for g in groups}
    read = "contact" in groups or ("stance" in groups and stance is None)
    touch = mujoco_touch(mj, datas, leg_of) if read else None
    adr = [mj.jnt_qposadr[_joint_id(mj, model.joint_names[j])] for j in model.ctrl_joint]
    vadr = _root_dof(model, mj)
    for k, d in enumerate(datas):
        if "angles" in groups:
            parts["angles"].append(d.qpos[adr])
        if "tilt" in groups or "rates" in groups:
            R = quat_to_mat_np(d.qpos[root][3:])
            ux, uy, uz = R[2, 0], R[2, 1], R[2, 2]
            wb = d.qvel[vadr + 3: vadr + 6]
            if "tilt" in groups:
                parts["tilt"].append([np.arctan2(-ux, uz), np.arctan2(uy, uz)])
            if "rates" in groups:
                parts["rates"].append([wb[1], wb[0]])
        if "contact" in groups:
            parts["contact"].append(touch[k])
        if "stance" in groups:
            parts["stance"].append(touch[k] if stance is None else stance[k])
    N = len(datas)
    out = []
    for g in sensors.GROUPS:
        if g not in groups:
            continue
        if g == "phase":
            out.append(np.stack(phase, 1))
        elif g == "command":
            out.append(np.asarray(command, float).reshape(N, 1))
        elif g == "steer":
            out.append(np.stack(phase, 1) * np.asarray(command, float).reshape(N, 1))
        elif g == "turn":
            out.append(np.abs(np.asarray(command, float)).reshape(N, 1))
        elif g == "bias":
            out.append(np.ones((N, 1)))
        else:
            out.append(np.asarray(parts[g], float).reshape(N, -1))
    return np.concatenate(out, 1)


def _joint_id(mj, name: str) -> int:
    import mujoco

    return mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_JOINT, name)


def _root_dof(model, mj) -> int:
    import mujoco

    bid = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, model.body_names[model.track])
    return int(mj.jnt_dofadr[mj.body_jntadr[bid]])


_CONTROL_DT: contextvars.ContextVar[float | None] = contextvars.ContextVar("mujoco_control_dt", default=None)


@contextlib.contextmanager
def control_period(seconds: float | None):
    """Within this block MuJoCo C runs closed-loop controllers with this control period (None: the model's step, as
    here; MuJoCo's own step: every step, as before the period was held), for ``cpgjax agreement
    --mujoco-control-dt`` (docs/results/walker.md)."""
    if seconds is not None and not (np.isfinite(seconds) and seconds > 0):
        raise ValueError(f"a control period must be a number of seconds > 0, got {seconds}")
    token = _CONTROL_DT.set(seconds)
    try:
        yield
    finally:
        _CONTROL_DT.reset(token)


def control_hold(model, timestep: float) -> int:
    """MuJoCo's steps per control period, at least 1: the period is an enclosing :func:`control_period`'s, else the
    model's step (the robot's control period here)."""
    control_dt = _CONTROL_DT.get()
    return max(1, int(round((model.dt if control_dt is None else control_dt) / timestep)))


def mujoco_closed_run(model, controller, *, time: float, delta: float = DEFAULT_DELTA,
                      timestep: float = MJ_TIMESTEP, latency: int = 0, mj=None, record: bool = False, steer=None,
                      watch=None):
    """Roll out N closed-loop controllers (a :class:`~cpgjax.episode.policy.ClosedLoop`, robots first) in MuJoCo C,
    one step at a time: each step the observation is computed from MuJoCo's state (:func:`mujoco_observe`), the
    policy acts on it (numpy, the formulas of :mod:`cpgjax.episode.policy`) and the servo targets go to the position
    actuators as in :func:`controls`.  Returns (metrics, qpos [N, S, nq], wall); with ``record`` also the
    observations [N, S - 1, n] (the one each step read, from t = 0).  ``steer``: ``steer(step, datas)`` gives, before
    every step, the command [N] the policy reads, computed from MuJoCo's state (:mod:`cpgjax.crosscheck.follow`),
    instead of the controller's constant one; None ends the episode there (qpos [N, step + 1, nq]).  ``watch``:
    ``watch(step, datas)`` after every step (``step`` from 1), to read what qpos does not hold (contacts:
    :mod:`cpgjax.crosscheck.agreement`).

    The controller runs at the robot's control period (:func:`control_hold`: the model's step, at which it runs
    here): where MuJoCo integrates with a shorter step, the observation, the command and the action are taken
    once per period and held in between, as our step holds them, so that the
    controller reads, acts and lags (``latency``: one control period) as here, whatever MuJoCo's step.
    ``observations`` and ``steer`` are then per control period.
    """
    from cpgjax.episode import policy as pol
    from cpgjax.episode import sensors as pol_sensors

    mj = mj if mj is not None else load(model, timestep=timestep)
    dt = mj.opt.timestep
    nstep = int(round(time / dt))
    hold = control_hold(model, dt)
    fam = controller.family
    C = np.asarray(controller.coeffs, np.float64)                   # [N, n_ctrl, 2K+1]
    W = np.asarray(controller.weights, np.float64)                  # [N, out, in]
    N = C.shape[0]
    cmd = np.zeros(N) if controller.command is None else np.asarray(controller.command, float).reshape(N)
    K, f0, n = model.episode.harmonics, model.episode.frequency, model.n_ctrl
    cj = model.ctrl_joint
    ratio = np.where(model.j_kp[cj] > 0, model.j_kd[cj] / np.maximum(model.j_kp[cj], 1e-12), 0.0)
    lim = pol.LIMITS
    leg_of = foot_geoms(model, mj)
    law = stepper(model, mj, N)
    datas = [from_rest(model, mj, law, i) for i in range(N)]
    q0 = initial_qpos(model, mj)
    qpos = np.zeros((N, nstep + 1, mj.nq))
    qpos[:, 0] = q0
    obs_log = [] if record else None
    phase_d = np.zeros(N)
    prev = stance = None
    k = np.arange(1, K + 1)[:, None]                                # [K, 1]
    w0 = 2 * np.pi * f0
    t0 = _time.perf_counter()
    for s in range(nstep):
        if s % hold == 0:    # a control period begins: read, act, and hold the action
            if steer is not None:
                cmd = steer(s, datas)
                if cmd is None:
                    qpos = qpos[:, : s + 1]
                    break
            tau = s * dt + phase_d                                      # [N]
            ang = w0 * k * tau[None]                                    # [K, N]
            sn, cs = np.sin(ang), np.cos(ang)
            phase = (sn[0], cs[0]) if K else (np.zeros(N), np.zeros(N))
            if "stance" in fam.inputs:   # the touch sensors low-passed, from the first reading on
                raw = mujoco_touch(mj, datas, leg_of)
                stance = raw if s == 0 else pol_sensors.stance_update(model, stance, raw)
            obs = mujoco_observe(model, mj, datas, fam.inputs, phase, cmd, leg_of, stance)
            if record:
                obs_log.append(obs)
            used = prev if (latency and prev is not None) else obs
            prev = obs
            u = (W * used[:, None, :]).sum(2)                           # [N, out]
            off = np.clip(u[:, :n], *lim["offsets"])
            mf = np.clip(u[:, n], *lim["frequency"])
            ma = np.clip(u[:, n + 1], *lim["amplitude"])
            osc = np.einsum("nck,kn->nc", C[:, :, 1::2], sn) + np.einsum("nck,kn->nc", C[:, :, 2::2], cs)
            dosc = np.einsum("nck,kn->nc", C[:, :, 1::2], w0 * k * cs) - np.einsum("nck,kn->nc", C[:, :, 2::2],
                                                                                  w0 * k * sn)
            q = C[:, :, 0] + (1.0 + ma)[:, None] * osc + off
            dq = dosc * ((1.0 + mf) * (1.0 + ma))[:, None]
            u_act = q + ratio[None] * dq
        for i, d in enumerate(datas):
            d.ctrl[:] = u_act[i]
            step(mj, d, law, i)
            qpos[i, s + 1] = d.qpos
        if watch is not None:
            watch(s + 1, datas)
        phase_d = phase_d + dt * mf
    wall = _time.perf_counter() - t0
    out = (_metrics(model, mj, qpos, dt, delta), qpos, wall)
    return out + (np.stack(obs_log, 1),) if record else out
