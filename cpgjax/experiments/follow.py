"""``cpgjax follow``: walk a path by choosing, every gait cycle, a gait of a speed-turn repertoire (beyond the thesis).

The robot walks from its initial pose (at the origin, facing +y).  At the start of every gait cycle (one
period ``1 / f0`` of the CPGs, 2 s for the thesis's 0.5 Hz, so every gait starts at phase 0 as it did in
the repertoire) it looks at the heading error ``e`` to the next waypoint and wants the turning rate
``w* = e / period`` (to turn the error out in one cycle).  Among the *forward* elites (heading speed at
least half the repertoire's fastest) it takes the one whose turning rate is closest to ``w*`` (ties: the
faster), and runs it for one cycle, the simulation carried on from the state the last cycle ended in.
A waypoint within ``reach`` of the tracked body's CM is passed; the walk ends at the last one, after
``cycles`` cycles, or when the body tilts past 60 degrees (a fall: ``FALL_TILT``).

Measured (:func:`follow`): the mean distance of the tracked body's CM from the path (the polyline from
the origin through the waypoints), sampled at the model's log rate, and the time to pass the last waypoint.

Paths (``--path``; metres): ``line:L`` (straight ahead), ``square:S`` (a square of side S turning left),
``circle:R`` (16 waypoints on a circle of radius R to the left), ``figure8:R`` (a circle to the left, then
one to the right), ``points:X,Y;X,Y;...``.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.episode import descriptors as bd
from cpgjax.episode.batch import LANES
from cpgjax.episode.cpg import targets
from cpgjax.episode.rollout import FALL_TILT
from cpgjax.errors import ResultsError
from cpgjax.experiments.repertoire import read_repertoire
from cpgjax.io.wl import load_model
from cpgjax.sim.rotation import quat_to_mat
from cpgjax.sim.state import initial_state, sim_time
from cpgjax.sim.step import step

PATHS = ("line", "square", "circle", "figure8", "points")


def waypoints(spec: str) -> np.ndarray:
    """The waypoints [n, 2] of a path specification (see the module docstring); bad input: ValueError."""
    kind, _, arg = spec.partition(":")
    if kind not in PATHS:
        raise ValueError(f"--path {spec!r}: expected one of {', '.join(p + ':...' for p in PATHS)}")
    if kind == "points":
        try:
            pts = np.asarray([[float(v) for v in p.split(",")] for p in arg.split(";") if p.strip()], float)
        except ValueError:
            pts = np.zeros((0, 1))
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) == 0 or not np.isfinite(pts).all():
            raise ValueError(f"--path {spec!r}: expected points:X,Y;X,Y;... (metres)")
        return pts
    try:
        size = float(arg)
    except ValueError:
        size = float("nan")
    if not (size > 0 and math.isfinite(size)):
        raise ValueError(f"--path {spec!r}: the size must be a number > 0 (metres)")
    if kind == "line":
        return np.asarray([[0.0, size]])
    if kind == "square":
        return np.asarray([[0.0, size], [-size, size], [-size, 0.0], [0.0, 0.0]])
    a = np.linspace(0, 2 * np.pi, 17)[1:]
    left = np.stack([-size + size * np.cos(a), size * np.sin(a)], 1)       # centre (-R, 0), counter-clockwise
    if kind == "circle":
        return left
    right = np.stack([size - size * np.cos(a), size * np.sin(a)], 1)      # centre (+R, 0), clockwise
    return np.concatenate([left, right])


def path_distance(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Distance [n] of points [n, 2] from the polyline ``path`` [m, 2]."""
    a, b = path[:-1], path[1:]
    ab = b - a
    L2 = np.maximum((ab * ab).sum(1), 1e-12)
    t = np.clip(((points[:, None] - a[None]) * ab[None]).sum(-1) / L2[None], 0.0, 1.0)
    near = a[None] + t[..., None] * ab[None]
    return np.sqrt(((points[:, None] - near) ** 2).sum(-1)).min(1)


def _cycle_fn(model, steps: int, sub: int):
    """Jitted ``(state, coeffs [n_ctrl, 2K+1, LANES]) -> (state, (x [S, 3, nb], q [S, 4, nb]))``: one gait cycle.

    The robot runs as robot 0 of a whole SIMD vector of copies (:data:`cpgjax.episode.batch.LANES`), as the
    repertoire's evaluation ran it: a batch narrower than that is computed with other instructions, and an
    evolved gait is chaotic enough that the last bits decide whether it falls (measured: the speed-turn
    repertoire's straight gait walks 2 s in a batch of 16 and turns over in a batch of 1 or 2)."""
    K, f0 = model.harmonics, model.frequency

    def run(state, coeffs):
        def inner(s, _):
            return step(model, s, targets(coeffs, sim_time(model, s), K, f0)), None

        def outer(s, _):
            s, _ = jax.lax.scan(inner, s, None, length=sub)
            return s, (s.x[..., 0], s.q[..., 0])

        return jax.lax.scan(outer, state, None, length=steps // sub)

    return jax.jit(run)


def follow(model_path: str, repertoire: str, path: str, *, cycles: int | None = None, reach: float = 0.2,
           video: str | None = None, min_speed: float = 0.5, max_tilt: float | None = None) -> dict:
    """Walk ``path`` choosing gaits of ``repertoire`` (see the module docstring); returns the walk and its measures."""
    rep = read_repertoire(repertoire)
    if tuple(rep.grid.names) != ("heading_speed", "turn"):
        raise ResultsError(f"{repertoire}: follow chooses gaits by turning rate: it needs a speed-turn repertoire "
                           f"(this one's descriptor is {rep.meta.get('descriptor')})")
    pts = waypoints(path)
    model = load_model(model_path, pipeline=str(rep.meta.get("pipeline") or "springs"))
    if rep.meta.get("model_text") and model.description.text != rep.meta["model_text"]:
        raise ResultsError(f"{model_path}: not the model the repertoire {repertoire} was made with")
    period = 1.0 / model.frequency
    steps = int(round(period / model.dt))
    sub = max(1, int(round(1.0 / (model.log_rate * model.dt))))
    steps -= steps % sub
    idx = rep.cells
    speed = rep.descriptors[idx, 0]
    fwd = speed >= min_speed * speed.max() if speed.max() > 0 else np.ones(len(idx), bool)
    if max_tilt is not None and "tilt" in rep.metrics:
        fwd &= rep.metrics["tilt"][idx] <= max_tilt
    if not fwd.any():
        raise ResultsError(f"{repertoire}: no elite walks forward with a mean tilt <= {max_tilt} rad")
    cand = idx[fwd]
    run = _cycle_fn(model, steps, sub)
    state = initial_state(model, LANES)
    track = model.track
    xs, qs, log = [np.asarray(state.x)[..., 0][None]], [np.asarray(state.q)[..., 0][None]], []
    k, finished, t_finish, fell = 0, False, float("nan"), None
    for c in range(cycles or 40):
        R = quat_to_mat(state.q)
        psi = float(bd.heading(model, R)[0])
        xy = np.asarray(state.x[:2, track, 0], float)
        d = pts[k] - xy
        bearing = math.atan2(-d[0], d[1])
        err = math.atan2(math.sin(bearing - psi), math.cos(bearing - psi))
        want = err / period
        score = np.abs(rep.descriptors[cand, 1] - want) - 1e-6 * rep.descriptors[cand, 0]
        cell = int(cand[int(np.argmin(score))])
        coeffs = jnp.asarray(np.repeat(rep.genomes[cell].reshape(model.n_ctrl, model.n_coeff)[..., None], LANES, -1))
        state, (x, q) = run(state, coeffs)
        x, q = np.asarray(x), np.asarray(q)
        if not (np.isfinite(x).all() and np.isfinite(q).all()):
            fell = "diverged"
            break
        xs.append(x)
        qs.append(q)
        up = 1.0 - 2.0 * (q[:, 1, track] ** 2 + q[:, 2, track] ** 2)        # cos of the body's tilt (R_zz)
        if np.any(up < math.cos(FALL_TILT)):
            fell = "fell"
        log.append({"cycle": c, "cell": cell, "want_turn": want, "turn": float(rep.descriptors[cell, 1]),
                    "speed": float(rep.descriptors[cell, 0]), "waypoint": k})
        for j in range(len(x)):          # waypoints passed during the cycle
            if np.hypot(*(x[j, :2, track] - pts[k])) < reach:
                k += 1
                if k == len(pts):
                    finished, t_finish = True, c * period + (j + 1) * sub * model.dt
                    break
        if finished or fell:
            break
    X, Q = np.concatenate(xs), np.concatenate(qs)
    traj = X[:, :2, track]
    poly = np.concatenate([[[0.0, 0.0]], pts])
    err = path_distance(traj, poly)
    out = {"path": path, "waypoints": len(pts), "reached": k, "finished": finished, "fell": fell,
           "time": t_finish if finished else len(log) * period, "cycles": len(log),
           "mean_error": float(err.mean()), "max_error": float(err.max()), "gaits": log,
           "trajectory": traj.tolist(), "waypoint_xy": pts.tolist(), "repertoire": repertoire}
    if video:
        _render(model, X, Q, sub * model.dt, video, f"follow {path}")
    return out


def _render(model, X, Q, dt_sample: float, out: str, title: str, fps: float = 5.0, size: int = 300) -> None:
    """The walk's samples drawn from a fixed camera, about ``fps`` frames per simulated second."""
    from cpgjax.render.movie import episode_frames, open_painter
    from cpgjax.render.poses import Poses, _frames_from_cm
    from cpgjax.render.video import VideoWriter, check_output

    check_output(out)
    stride = max(1, int(round(1.0 / (fps * dt_sample))))
    X, Q = X[::stride], Q[::stride]
    pos, quat = _frames_from_cm(model, X.astype(float), Q.astype(float))
    poses = Poses(t=np.arange(len(X)) * dt_sample * stride, pos=pos, quat=quat, label="follow", fitness=float("nan"))
    with open_painter(model, poses, size, size) as painter, VideoWriter(out, 1.0 / (dt_sample * stride)) as w:
        for img in episode_frames(painter, [poses], "fixed", title=title):
            w.append(img)
