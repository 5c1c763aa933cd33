"""``cpgjax follow --ctl``: walk paths with a closed-loop gait that reads a commanded turning rate (beyond the thesis).

The gait alone, as a robot would walk it: the whole path is one episode of the one controller, and the command
it reads is computed inside the episode's scan, every step, from the robot's own pose (the heading error to the
next waypoint, a proportional law clipped to the command's range: :class:`cpgjax.episode.steering.Course`).
Nothing is simulated ahead and nothing is chosen among gaits (against ``cpgjax follow --repertoire``, whose
look-ahead's simulation is the walk: :mod:`cpgjax.experiments.follow`).

Every controller x path is one robot of one batch (one compiled program; on exact joints a robot's result does
not depend on the batch it runs in, :func:`cpgjax.episode.batch.lanes`).  Measured per walk, from the log samples
(the model's log rate): finished (the last waypoint passed before any fall), the time at which it was, a fall
(the body tilted past 60 degrees before finishing; ``FALL_TILT``), the waypoints passed, and the mean and largest
distance of the tracked body's CM from the path (the polyline from the origin through the waypoints) until the
walk ends (finished, fell, or the episode's end).

``engine="mujoco"`` walks the same controllers and paths in MuJoCo C instead (the robot, :mod:`cpgjax.crosscheck.
follow`): the policy reads MuJoCo's sensors and the command is computed every control period (the model's step) from
MuJoCo's own pose by the same law, sampled at the same log rate and measured by the same :func:`measure`;
``engine="both"`` walks each in ours, then in MuJoCo.
"""

from __future__ import annotations

import math

import numpy as np

from cpgjax.episode import policy as pol
from cpgjax.episode import steering
from cpgjax.episode.batch import simulate
from cpgjax.episode.rollout import FALL_TILT
from cpgjax.experiments.follow import path_distance, render_walk, waypoints
from cpgjax.io.ctl import read_ctl
from cpgjax.io.wl import load_model

TIME = 120.0     # s: the longest walk
GAIN = steering.GAIN
ENGINES = ("ours", "mujoco", "both")   # where a walk runs: our simulator, MuJoCo C (the robot), or both
LIMIT = 0.3      # rad/s: the command's range, the robust evaluation's ``command`` of docs/closed-loop.md's recipe


def controller(path: str, model):
    """The one-robot :class:`~cpgjax.episode.policy.ClosedLoop` of a `.ctl` file; it must read the command."""
    c = pol.from_control(read_ctl(path, n_dof=model.n_ctrl, harmonics=model.episode.harmonics), model)
    if not pol.is_closed(c) or not {"command", "steer"} & set(c.family.inputs):
        raise ValueError(f"--ctl {path}: a controller that reads the commanded turning rate is needed "
                         "(evolved with --controller pmtg:...+command+... or ...+steer+... and --perturb command=R)")
    return c


def measure(t, wp, up, xy, command, pts: np.ndarray) -> tuple[dict, int]:
    """The measures of one walk (see the module docstring) from its log samples: times ``t`` [S] (s), the next
    waypoint ``wp`` [S], the cosine of the tracked body's tilt ``up`` [S], its CM ``xy`` [S, 2] (m), the command
    ``command`` [S] (rad/s), on the path of waypoints ``pts`` [n, 2]; and the sample at which the walk ends."""
    fallen = np.nonzero(up < math.cos(FALL_TILT))[0]
    done = np.nonzero(wp >= len(pts))[0]
    j_fall = int(fallen[0]) if len(fallen) else None
    j_done = int(done[0]) if len(done) else None
    finished = j_done is not None and (j_fall is None or j_done < j_fall)
    end = j_done if finished else j_fall if j_fall is not None else len(t) - 1
    xy = xy[: end + 1]
    err = path_distance(xy, np.concatenate([[[0.0, 0.0]], pts]))
    return {"finished": bool(finished), "time": float(t[end]),
            "fell": None if finished or j_fall is None else float(t[j_fall]),
            "reached": int(wp[end]), "waypoints": len(pts), "mean_error": float(err.mean()),
            "max_error": float(err.max()), "tilt_max": float(np.arccos(np.clip(up[: end + 1], -1, 1)).max()),
            "command_mean_abs": float(np.abs(command[: end + 1]).mean()),
            "trajectory": xy.tolist(), "waypoint_xy": pts.tolist()}, end


def walks(model_path: str, ctls: list[str], paths: list[str], *, time: float = TIME, gain: float = steering.GAIN,
          limit: float = LIMIT, reach: float = steering.REACH, pipeline: str | None = None,
          video: str | None = None, engine: str = "ours", mujoco_dt: float | None = None) -> list[dict]:
    """Walk every path with every controller (see the module docstring); one dict per walk, controllers outer.

    ``engine``: ``ours`` (our simulator, on ``pipeline``), ``mujoco`` (MuJoCo C at the step ``mujoco_dt``, None: the
    export's, :mod:`cpgjax.crosscheck.follow`) or ``both`` (each walk ours, then MuJoCo's); with ``mujoco`` or
    ``both`` every dict names its ``engine``.  ``video`` draws our simulator's walk."""
    if engine not in ENGINES:
        raise ValueError(f"--engine {engine!r}: expected one of {', '.join(ENGINES)}")
    if video and engine == "mujoco":
        raise ValueError("--video draws our simulator's walk: with --engine ours or both")
    model = load_model(model_path, pipeline=pipeline)
    pts = {p: waypoints(p) for p in paths}
    cs = [controller(c, model) for c in ctls]
    pairs = [(i, p) for i in range(len(ctls)) for p in paths]
    batch = pol.stack([cs[i] for i, _ in pairs], model)
    if engine == "mujoco":
        return _mujoco(model, batch, ctls, pairs, pts, time, gain, limit, reach, mujoco_dt)
    batch_ours = batch.replace(steer=steering.course([pts[p] for _, p in pairs], gain, limit, reach))
    r = simulate(model, batch_ours, time=time, record=True)
    tr = r["traj"]
    t = np.asarray(tr["t"], float)
    track = model.track
    out = []
    for b, (i, p) in enumerate(pairs):
        q = np.asarray(tr["q"][:, :, track, b], float)
        up = 1.0 - 2.0 * (q[:, 1] ** 2 + q[:, 2] ** 2)
        w, end = measure(t, np.asarray(tr["waypoint"][:, b]), up, np.asarray(tr["x"][:, :2, track, b], float),
                         np.asarray(tr["command"][:, b]), pts[p])
        out.append({"ctl": ctls[i], "path": p} | w | {"gain": gain, "limit": limit, "pipeline": model.pipeline})
    if video:
        if len(pairs) != 1:
            raise ValueError("--video draws one walk: give one --ctl and one --path")
        X = np.asarray(tr["x"][..., 0], float)[: end + 1]
        Q = np.asarray(tr["q"][..., 0], float)[: end + 1]
        render_walk(model, X, Q, float(t[1] - t[0]), video, f"follow {paths[0]}", waypoints=pts[paths[0]],
                    passed=np.asarray(tr["waypoint"][: end + 1, 0]))
    if engine == "both":
        theirs = _mujoco(model, batch, ctls, pairs, pts, time, gain, limit, reach, mujoco_dt)
        out = [w for a, b in zip(out, theirs, strict=True) for w in ({"engine": "ours"} | a, b)]
    return out


def _mujoco(model, batch, ctls, pairs, pts, time, gain, limit, reach, mujoco_dt) -> list[dict]:
    """The walks of ``pairs`` in MuJoCo C (:func:`cpgjax.crosscheck.follow.walk`), measured as ours."""
    from cpgjax.crosscheck.follow import walk as mujoco_walk
    from cpgjax.crosscheck.impedance import current_law

    r = mujoco_walk(model, batch, [pts[p] for _, p in pairs], time=time, gain=gain, limit=limit, reach=reach,
                    timestep=mujoco_dt)
    law = current_law()             # MuJoCo C's contact law (crosscheck.impedance), recorded with each walk
    out = []
    for b, (i, p) in enumerate(pairs):
        w, _ = measure(r["t"], r["waypoint"][b], r["up"][b], r["xy"][b], r["command"][b], pts[p])
        out.append({"engine": "mujoco", "ctl": ctls[i], "path": p} | w | {"gain": gain, "limit": limit,
                                                                          "mujoco_dt": r["dt"], "mujoco_contact": law})
    return out
