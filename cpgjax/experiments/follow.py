"""``cpgjax follow``: walk a path by choosing, every gait cycle, a gait of a speed-turn repertoire (beyond the thesis).

The robot walks from its initial pose (at the origin, facing +y).  At the start of every gait cycle (one
period ``1 / f0`` of the CPGs, 2 s for the thesis's 0.5 Hz, so every gait starts at phase 0 as it did in
the repertoire) it looks at the heading error ``e`` to the next waypoint and wants the turning rate
``w* = e / period`` (to turn the error out in one cycle).  The candidates are the *forward* elites (heading
speed at least ``min_speed`` of the repertoire's fastest) ordered by how close their turning rate is to
``w*`` (ties: the faster).

- **Look-ahead** (``lookahead`` K > 0, the default 64; model-predictive choice from the repertoire): the K
  nearest candidates are simulated for the coming cycle, all at once in one batch, from the state the
  robot is in; those whose body tilts more than ``safe_tilt`` (0.8 rad) at any sample of the cycle are
  dropped, and of the rest the robot walks the one of least cost: the length of the path still to walk
  from where the cycle ends (through the waypoints not yet passed; a candidate that finishes beats any
  that does not, the earlier the better) + ``deviation`` x its mean distance from the path during the
  cycle + ``aim`` x its heading error to its next waypoint at the cycle's end.  If none is safe, the
  least tilted.  The walk is the chosen candidate's own simulation (its state carried on to the next
  cycle, copied to the whole batch): in the simulator the prediction is exact, so what the look-ahead buys
  is the choice, not a model.  Without the tilt bound it chooses gaits that tumble forward
  (docs/results/repertoire-steering.md), so the bound is what keeps the robot up.
- **Nearest turn** (``lookahead=0``; forward elites at least half the fastest): the candidate whose turning
  rate is closest to ``w*``, run as one of a whole SIMD vector of copies (``_cycle_fn``).

Every cycle carries the simulation on from the state the last one ended in.  A waypoint within ``reach`` of
the tracked body's CM is passed; the walk ends at the last one, after ``cycles`` cycles, or when the body
tilts past 60 degrees (a fall: ``FALL_TILT``).

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
from cpgjax.episode.batch import lanes
from cpgjax.episode.cpg import targets
from cpgjax.episode.rollout import FALL_TILT
from cpgjax.errors import ResultsError
from cpgjax.experiments.repertoire import read_repertoire
from cpgjax.io.wl import load_model
from cpgjax.sim.pipeline import step
from cpgjax.sim.rotation import quat_to_mat
from cpgjax.sim.state import initial_state, sim_time

PATHS = ("line", "square", "circle", "figure8", "points")
LOOKAHEAD = 64          # candidate gaits simulated ahead every cycle (0: the nearest-turn rule)
SAFE_TILT = 0.8         # rad (46 deg): a candidate whose body tilts more during the cycle is not taken
DEVIATION = 1.0         # weight of the mean distance from the path (m) in a candidate's cost (m)
AIM = 0.3               # m/rad: weight of the heading error to the next waypoint at the cycle's end
MIN_SPEED = 0.5         # the candidates: elites at least this share of the fastest's heading speed ...
MIN_SPEED_LOOKAHEAD = 0.2   # ... with the look-ahead (slower gaits turn tighter; the look-ahead judges them)


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
    """Jitted ``(state, coeffs [n_ctrl, 2K+1, B]) -> (state, (x [S, 3, nb, B], q [S, 4, nb, B]))``: one gait
    cycle of B robots, sampled at the log rate (B from `cpgjax.episode.batch.lanes`).

    The robot runs as robot 0 of a whole SIMD vector of copies (:data:`cpgjax.episode.batch.LANES`), as the
    repertoire's evaluation ran it: a batch narrower than that is computed with other instructions, and an
    evolved gait is chaotic enough that the last bits decide whether it falls (docs/results/repertoire-steering.md:
    a gait that walks in a batch of 16 and turns over in a batch of 1 or 2)."""
    K, f0 = model.episode.harmonics, model.episode.frequency

    def run(state, coeffs):
        def inner(s, _):
            return step(model, s, targets(coeffs, sim_time(model, s), K, f0)), None

        def outer(s, _):
            s, _ = jax.lax.scan(inner, s, None, length=sub)
            return s, (s.x, s.q)

        return jax.lax.scan(outer, state, None, length=steps // sub)

    return jax.jit(run)


def _lane(state, i: int, B: int):
    """``state`` with every robot a copy of robot ``i`` (B robots)."""
    return jax.tree_util.tree_map(lambda a: jnp.repeat(a[..., i:i + 1], B, -1) if a.ndim else a, state)


def _remaining(pts: np.ndarray, k: int, xy: np.ndarray) -> float:
    """Length of the path still to walk from ``xy`` through waypoints ``k..``."""
    if k >= len(pts):
        return 0.0
    tail = np.hypot(*np.diff(pts[k:], axis=0).T).sum() if len(pts) - k > 1 else 0.0
    return float(np.hypot(*(pts[k] - xy)) + tail)


def judge(xy, up, psi_end, ok, pts: np.ndarray, k: int, *, reach: float = 0.2, deviation: float = DEVIATION,
          aim: float = AIM):
    """Judge n candidate cycles: ``xy`` [S, 2, n] the tracked body's ground positions at the samples, ``up``
    [S, n] the cosine of its tilt, ``psi_end`` [n] its heading at the cycle's end, ``ok`` [n] finite; the next
    waypoint is ``pts[k]``.  Returns ``(passed, done_at, tilt, cost)`` [n]: waypoints passed, the sample at
    which the last one is (-1: not), the largest tilt (rad; inf if not finite), and the cost the look-ahead
    minimises (module docstring; inf if not finite)."""
    xy, up = np.asarray(xy, float), np.asarray(up, float)
    n = xy.shape[-1]
    poly = np.concatenate([[[0.0, 0.0]], pts])
    tilt = np.where(ok, np.arccos(np.clip(np.nan_to_num(up, nan=-1.0), -1, 1)).max(0), np.inf)
    passed, done_at, cost = np.zeros(n, int), np.full(n, -1), np.full(n, np.inf)
    for b in range(n):
        kb = k
        for j in range(len(xy)):
            if kb < len(pts) and np.hypot(*(xy[j, :, b] - pts[kb])) < reach:
                kb += 1
                if kb == len(pts):
                    done_at[b] = j
                    break
        passed[b] = kb - k
        if not ok[b]:
            continue
        cost[b] = (_remaining(pts, kb, xy[-1, :, b]) + deviation * float(path_distance(xy[:, :, b], poly).mean()))
        if done_at[b] >= 0:
            cost[b] = -1e3 + 1e-3 * done_at[b]            # finishing beats anything, the sooner the better
        else:
            de = pts[kb] - xy[-1, :, b]
            e = math.atan2(-de[0], de[1]) - float(psi_end[b])
            cost[b] += aim * abs(math.atan2(math.sin(e), math.cos(e)))
    return passed, done_at, tilt, cost


def pick(cost, tilt, safe_tilt: float = SAFE_TILT) -> int:
    """The candidate of least cost among those whose tilt is at most ``safe_tilt``; if none, the least tilted."""
    cost, tilt = np.asarray(cost, float), np.asarray(tilt, float)
    safe = tilt <= safe_tilt
    return int(np.argmin(np.where(safe, cost, np.inf))) if safe.any() else int(np.argmin(tilt))


def follow(model_path: str, repertoire: str, path: str, *, cycles: int | None = None, reach: float = 0.2,
           video: str | None = None, min_speed: float | None = None, max_tilt: float | None = None,
           lookahead: int = LOOKAHEAD, safe_tilt: float = SAFE_TILT, deviation: float = DEVIATION,
           aim: float = AIM, replay: bool = False, copies: int = 1, jitter: float = 0.01) -> dict:
    """Walk ``path`` choosing gaits of ``repertoire`` (see the module docstring); returns the walk and its measures.

    ``lookahead`` 0: the nearest-turn rule; K > 0: the K candidates whose turning rate is nearest ``w*`` are
    simulated for the coming cycle from the robot's state, and the one of least cost (:func:`judge`) among
    those whose body tilts at most ``safe_tilt`` (rad) is walked (:func:`pick`).  ``min_speed`` (the
    candidates' least heading speed, a share of the fastest elite's): 0.2 with the look-ahead, else 0.5.
    ``replay``: the walk is not the chosen candidate's simulation but the chosen gait run again from the same
    state alone (a batch of one robot: other instructions, so other last bits, and a chaotic gait diverges
    from its prediction: a look-ahead whose model is not exact; docs/results/repertoire.md measures what it changes).
    ``copies`` M > 1: each candidate is simulated as M copies, copies 1..M-1 with every body's velocity and
    angular velocity jittered by N(0, ``jitter``) (m/s, rad/s), and judged by its worst copy's tilt."""
    rep = read_repertoire(repertoire)
    if tuple(rep.grid.names) != ("heading_speed", "turn"):
        raise ResultsError(f"{repertoire}: follow chooses gaits by turning rate: it needs a speed-turn repertoire "
                           f"(this one's descriptor is {rep.meta.get('descriptor')})")
    if lookahead < 0:
        raise ValueError(f"lookahead must be >= 0, got {lookahead}")
    pts = waypoints(path)
    poly = np.concatenate([[[0.0, 0.0]], pts])
    model = load_model(model_path, pipeline=str(rep.meta.get("pipeline") or "springs"))
    if rep.meta.get("model_text") and model.description.text != rep.meta["model_text"]:
        raise ResultsError(f"{model_path}: not the model the repertoire {repertoire} was made with")
    period = 1.0 / model.episode.frequency
    steps = int(round(period / model.dt))
    sub = max(1, int(round(1.0 / (model.episode.log_rate * model.dt))))
    steps -= steps % sub
    if min_speed is None:
        min_speed = MIN_SPEED_LOOKAHEAD if lookahead else MIN_SPEED
    idx = rep.cells
    speed = rep.descriptors[idx, 0]
    fwd = speed >= min_speed * speed.max() if speed.max() > 0 else np.ones(len(idx), bool)
    if max_tilt is not None and "tilt" in rep.metrics:
        fwd &= rep.metrics["tilt"][idx] <= max_tilt
    if not fwd.any():
        raise ResultsError(f"{repertoire}: no elite walks forward with a mean tilt <= {max_tilt} rad")
    cand = idx[fwd]
    M = max(1, copies) if lookahead else 1
    B = lanes(model, min(lookahead, len(cand)) * M)     # whole SIMD vectors (on exact joints a power of two)
    rng = np.random.default_rng(0)
    run = _cycle_fn(model, steps, sub)
    state = initial_state(model, B)
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
        order = cand[np.argsort(score, kind="stable")[:max(1, lookahead)]]
        cells = np.resize(np.repeat(order, M), B)   # the candidates (M copies each), repeated to fill the batch
        coeffs = np.stack([rep.genomes[i].reshape(model.n_ctrl, model.n_coeff) for i in cells], -1)
        start = state
        if M > 1:                                    # copies 1..M-1 of each candidate: the bodies' velocities jittered
            jit = (np.arange(B) % M != 0).astype(np.float32) * jitter
            start = state._replace(v=state.v + jnp.asarray(rng.standard_normal(state.v.shape) * jit, state.v.dtype),
                                   w=state.w + jnp.asarray(rng.standard_normal(state.w.shape) * jit, state.w.dtype))
        end, (x, q) = run(start, jnp.asarray(coeffs))
        psi_end = np.asarray(bd.heading(model, quat_to_mat(end.q)))
        x, q = np.asarray(x), np.asarray(q)          # [S, 3, nb, B], [S, 4, nb, B]
        ok = np.isfinite(x).all((0, 1, 2)) & np.isfinite(q).all((0, 1, 2))
        n = len(order) * M if lookahead else 1
        up = 1.0 - 2.0 * (q[:, 1, track, :n] ** 2 + q[:, 2, track, :n] ** 2)   # cos of the body's tilt (R_zz)
        passed, done_at, tilt, cost = judge(x[:, :2, track, :n], up, psi_end[:n], ok[:n], pts, k, reach=reach,
                                            deviation=deviation, aim=aim)
        if M > 1:                                    # a candidate is as tilted as its worst copy, as costly as copy 0
            worst = np.where(ok[:n].reshape(-1, M).all(1), tilt.reshape(-1, M).max(1), np.inf)
            tilt = np.full(n, np.inf)
            tilt[::M] = worst
        b = pick(cost, tilt, safe_tilt) if lookahead else 0
        cell = int(cells[b])
        n_safe = int((tilt <= safe_tilt).sum()) if lookahead else None
        if replay and lookahead:        # walk the chosen gait again, alone (a batch of 1: other instructions)
            end, (x, q) = run(_lane(state, 0, 1), jnp.asarray(coeffs[..., b:b + 1]))
            end = _lane(end, 0, B)
            x, q = np.asarray(x)[..., :1], np.asarray(q)[..., :1]
            ok = np.isfinite(x).all((0, 1, 2)) & np.isfinite(q).all((0, 1, 2))
            up = 1.0 - 2.0 * (q[:, 1, track] ** 2 + q[:, 2, track] ** 2)
            psi_end = np.asarray(bd.heading(model, quat_to_mat(end.q)))
            passed, done_at, tilt, _ = judge(x[:, :2, track], up, psi_end[:1], ok, pts, k, reach=reach)
            b = 0
        if not ok[b]:
            fell = "diverged"
            break
        xs.append(x[..., b])
        qs.append(q[..., b])
        log.append({"cycle": c, "cell": cell, "want_turn": want, "turn": float(rep.descriptors[cell, 1]),
                    "speed": float(rep.descriptors[cell, 0]), "waypoint": k, "tilt": float(tilt[b]),
                    "safe": n_safe})
        if tilt[b] > FALL_TILT:
            fell = "fell"
        if done_at[b] >= 0:
            finished, t_finish = True, c * period + (done_at[b] + 1) * sub * model.dt
        k += int(passed[b])
        state = _lane(end, b, B)
        if finished or fell:
            break
    X, Q = np.concatenate(xs), np.concatenate(qs)
    traj = X[:, :2, track]
    err = path_distance(traj, poly)
    out = {"path": path, "waypoints": len(pts), "reached": k, "finished": finished, "fell": fell,
           "time": t_finish if finished else len(log) * period, "cycles": len(log),
           "mean_error": float(err.mean()), "max_error": float(err.max()), "gaits": log, "lookahead": lookahead,
           "trajectory": traj.tolist(), "waypoint_xy": pts.tolist(), "repertoire": repertoire}
    if video:
        render_walk(model, X, Q, sub * model.dt, video, f"follow {path}", waypoints=pts)
    return out


def render_walk(model, X, Q, dt_sample: float, out: str, title: str, fps: float = 5.0, size: int = 300,
                waypoints: np.ndarray | None = None, passed: np.ndarray | None = None) -> None:
    """The walk's samples drawn from a fixed camera, about ``fps`` frames per simulated second; ``waypoints``
    [n, 2] the path's, drawn on the ground, ``passed`` [samples] how many of them each sample has passed."""
    from cpgjax.render.movie import episode_frames, open_painter
    from cpgjax.render.poses import Poses, frames_from_cm
    from cpgjax.render.video import VideoWriter, check_output

    check_output(out)
    stride = max(1, int(round(1.0 / (fps * dt_sample))))
    X, Q = X[::stride], Q[::stride]
    passed = None if passed is None else np.asarray(passed)[::stride]
    pos, quat = frames_from_cm(model, X.astype(float), Q.astype(float))
    poses = Poses(t=np.arange(len(X)) * dt_sample * stride, pos=pos, quat=quat, label="follow", fitness=float("nan"))
    with open_painter(model, poses, size, size) as painter, VideoWriter(out, 1.0 / (dt_sample * stride)) as w:
        for img in episode_frames(painter, [poses], "fixed", title=title, waypoints=waypoints, passed=passed):
            w.append(img)
