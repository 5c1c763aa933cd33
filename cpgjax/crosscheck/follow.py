"""A closed-loop gait walks a path in MuJoCo C, the turning command set every step from MuJoCo's own pose.

``cpgjax follow --ctl ... --engine mujoco`` (:mod:`cpgjax.experiments.steer`): the robot is the exported model
(:mod:`cpgjax.crosscheck.mjcf`), the controller runs on MuJoCo's sensors one step at a time
(:func:`cpgjax.crosscheck.engines.mujoco_closed_run`), and before every step the follower computes the command
it reads from MuJoCo's state alone, by our follower's law (:class:`cpgjax.episode.steering.Course`), here in
numpy (:class:`Follower`, float64): the heading ``psi`` of the tracked body's forward axis (its +y in world
coordinates) and its CM in the ground plane; the next waypoint passed when the CM comes within ``reach``; the
heading error ``e`` to it; ``c = clip(gain e, -limit, limit)``; ``c = 0`` after the last.  As ours, it is
computed once on the initial pose before the first step (the command at t = 0).

The walk is sampled as ours is, every ``round(1 / (log rate x MuJoCo's step))`` steps, and ends at the first
sample at which every robot has passed its last waypoint or tilted past 60 degrees (``FALL_TILT``), or at
the episode's end; :mod:`cpgjax.experiments.steer` measures the samples as it measures ours.
"""

from __future__ import annotations

import math

import numpy as np

from cpgjax.crosscheck.engines import control_hold, mujoco_closed_run, root_slice
from cpgjax.crosscheck.mjcf import initial_qpos, load
from cpgjax.episode.rollout import FALL_TILT
from cpgjax.episode.steering import GAIN, REACH
from cpgjax.sim.rotation import quat_to_mat_np


class Follower:
    """:class:`cpgjax.episode.steering.Course`'s law in numpy, one path per robot (waypoints [n_i, 2] each, m),
    its memory the next waypoint ``k`` [N] of each."""

    def __init__(self, paths: list[np.ndarray], gain: float = GAIN, limit: float = 0.4, reach: float = REACH):
        P = max(len(p) for p in paths)
        self.points = np.stack([np.concatenate([p, np.repeat(p[-1:], P - len(p), 0)]) for p in paths]).astype(float)
        self.count = np.asarray([len(p) for p in paths])
        self.gain, self.limit, self.reach = float(gain), float(limit), float(reach)
        self.k = np.zeros(len(paths), int)

    def _target(self) -> np.ndarray:
        return self.points[np.arange(len(self.k)), np.minimum(self.k, self.points.shape[1] - 1)]

    def command(self, psi, xy) -> np.ndarray:
        """The command [N] (rad/s) at heading ``psi`` [N] (rad) and CM ``xy`` [N, 2]; passes a waypoint within reach."""
        d = self._target() - xy
        self.k = self.k + ((np.hypot(d[:, 0], d[:, 1]) < self.reach) & (self.k < self.count))
        d = self._target() - xy
        e = np.arctan2(-d[:, 0], d[:, 1]) - psi
        e = np.arctan2(np.sin(e), np.cos(e))
        return np.where(self.k < self.count, np.clip(self.gain * e, -self.limit, self.limit), 0.0)


def pose(model, mj, qpos) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(psi, xy, up)`` of MuJoCo states ``qpos`` [..., nq]: the tracked body's heading [...] (rad, counter-clockwise
    from world +y, as `cpgjax.episode.descriptors.heading`), its CM in the ground plane [..., 2] and the cosine of
    its tilt [...]."""
    root = np.asarray(qpos, float)[..., root_slice(model, mj)]
    R = quat_to_mat_np(np.moveaxis(root[..., 3:], -1, 0))                      # [3, 3, ...]
    cm = root[..., :3] + np.einsum("ij...,j->...i", R, model.cm_local[:, model.track])
    return np.arctan2(-R[0, 1], R[1, 1]), cm[..., :2], R[2, 2]


def walk(model, controller, paths: list[np.ndarray], *, time: float, gain: float = GAIN, limit: float = 0.4,
         reach: float = REACH, timestep: float | None = None) -> dict:
    """Robot i of ``controller`` (a :class:`~cpgjax.episode.policy.ClosedLoop` of N, robots first) walks the
    waypoints ``paths[i]`` in MuJoCo C (step ``timestep``, None: the export's) for at most ``time`` s (see the module
    docstring).  Returns the log samples: ``t`` [S], and per robot (:func:`pose`) ``psi`` [N, S], ``xy`` [N, S, 2],
    ``up`` [N, S], the next
    waypoint ``waypoint`` [N, S] and ``command`` [N, S] (of the sample's last step; at t = 0 the first step's), and
    ``dt`` (MuJoCo's step)."""
    mj = load(model) if timestep is None else load(model, timestep=timestep)
    dt = float(mj.opt.timestep)
    inner = max(1, int(round(1.0 / (model.episode.log_rate * dt))))
    outer = max(1, int(math.ceil(round(time / dt, 6) / inner)))
    fol = Follower(paths, gain, limit, reach)
    psi0, xy0, _ = pose(model, mj, initial_qpos(model, mj)[None])
    c0 = fol.command(psi0, xy0)                                 # the command at t = 0 (ours: the first step's)
    ks, cs = [fol.k.copy()], [c0]
    settled = np.zeros(len(paths), bool)
    cos_fall = math.cos(FALL_TILT)

    hold = control_hold(model, dt)    # called every control period (engines.mujoco_closed_run): every hold steps

    def steer(s, datas):
        psi, xy, up = pose(model, mj, np.stack([d.qpos for d in datas]))
        if s and s // inner > (s - hold) // inner:    # the first period at or after a log sample: the walk ends
            settled[:] |= (fol.k >= fol.count) | (up < cos_fall)      # when every robot has finished or fallen
            if settled.all():
                return None
        c = fol.command(psi, xy)
        if (s + hold) // inner > s // inner:    # the period holding the last step before a log sample: its command
            ks.append(fol.k.copy())
            cs.append(c)
        return c

    _, qpos, _ = mujoco_closed_run(model, controller, time=inner * outer * dt, mj=mj, steer=steer)
    psi, xy, up = pose(model, mj, qpos[:, ::inner])
    return {"t": np.arange(len(ks)) * inner * dt, "psi": psi, "xy": xy, "up": up,
            "waypoint": np.stack(ks, 1), "command": np.stack(cs, 1), "dt": dt}
