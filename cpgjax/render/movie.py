"""One episode (or our episode beside MuJoCo's) rendered to a video: :func:`render_video`.

The order makes every failure cheap: the output path and its encoder are checked first, then
the GL back-end is opened (:class:`~cpgjax.render.scene.Painter`), then the episode is simulated
and recorded, and only then are frames drawn into a temporary file that is renamed at the end.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from cpgjax.render.poses import Poses, distance, record_mujoco, record_ours
from cpgjax.render.scene import Painter, View, checker, extent, views
from cpgjax.render.video import VideoWriter, check_output

ENGINES = ("ours", "mujoco", "both")


def caption(poses: Poses, k: int, dist: np.ndarray, cell: float, title: str | None = None) -> list[str]:
    """The caption of frame ``k``: the engine, the time, the distance walked so far; the episode's fitness (none
    for a walk that has none, NaN: a path followed)."""
    flag = "  DIVERGED" if poses.diverged else ("  fell" if poses.fallen else "")
    fit = "" if np.isnan(poses.fitness) else f"fitness {poses.fitness:+.4f}{flag}  "
    lines = [f"{poses.label}  t {poses.t[k]:5.2f} s  d {dist[k]:+.3f} m", f"{fit}grid {cell:g} m"]
    return ([title] if title else []) + lines


def episode_frames(painter: Painter, episodes: list[Poses], camera: str, *, title: str | None = None,
                   robot: bool = True, markers: bool = True, captions: bool = True,
                   waypoints: np.ndarray | None = None, passed: np.ndarray | None = None) -> Iterator[np.ndarray]:
    """The frames of one or more episodes of the same model (side by side), one array [H, W * n, 3] per time.
    ``waypoints`` [n, 2]: a path's, drawn on the ground; ``passed`` [frames]: how many of them each frame has passed
    (drawn in green and said in the caption; None: not known, nothing said)."""
    model = painter.model
    size = extent(model, episodes[0])
    vs: list[list[View]] = views(model, episodes, camera, painter.width / painter.height, size)
    dists = [distance(model, p) for p in episodes]
    n = min(p.frames for p in episodes)
    for k in range(n):
        done = 0 if passed is None else int(passed[k])
        where = [] if waypoints is None or passed is None else [f"waypoints {done} of {len(waypoints)}"]
        panes = [painter.frame(p, k, v[k], robot=robot, markers=markers, waypoints=waypoints, passed=done,
                               caption=caption(p, k, d, painter.cell, title) + where if captions else None)
                 for p, v, d in zip(episodes, vs, dists, strict=True)]
        yield panes[0] if len(panes) == 1 else np.concatenate(panes, axis=1)


def open_painter(model, poses_or_size, width: int, height: int) -> Painter:
    """A Painter whose ground squares and contact dots suit the robot's size (m, or that of ``Poses``)."""
    size = extent(model, poses_or_size) if isinstance(poses_or_size, Poses) else float(poses_or_size)
    return Painter(model, width, height, cell=checker(size), marker=float(np.clip(0.02 * size, 0.002, 0.02)))


def initial_poses(model) -> Poses:
    """The model's initial pose as a one-frame episode (for sizing the scene before simulating)."""
    from cpgjax.render.poses import frames_from_cm

    pos, quat = frames_from_cm(model, np.asarray(model.x0, float)[None], np.asarray(model.q0, float)[None])
    return Poses(t=np.zeros(1), pos=pos, quat=quat, label="initial", fitness=float("nan"))


def render_video(model, coeffs, out: str, *, time: float | None = None, fps: float = 30.0,
                 size: tuple[int, int] = (640, 480), camera: str = "track", engine: str = "ours",
                 title: str | None = None, progress: bool = True) -> dict:
    """Render one episode of ``coeffs`` [n_ctrl, 2K+1] on ``model`` to ``out`` (.mp4 or .gif).

    ``engine``: ``ours`` (our simulator's recorded poses), ``mujoco`` (MuJoCo C's episode of the
    same controller) or ``both`` (side by side, each pane ``size``).  Returns a summary: frames,
    fps, size, the GL back-end, and per engine its fitness and distance.
    """
    from tqdm.auto import tqdm

    if engine not in ENGINES:
        raise ValueError(f"engine {engine!r}: expected one of {', '.join(ENGINES)}")
    if camera not in ("track", "fixed", "side"):
        raise ValueError(f"camera {camera!r}: expected track, fixed or side")
    width, height = size
    check_output(out)
    with open_painter(model, initial_poses(model), width, height) as painter:
        ours = record_ours(model, coeffs, time=time, fps=fps)
        episodes = {"ours": [ours], "mujoco": [], "both": [ours]}[engine]
        if engine in ("mujoco", "both"):
            episodes.append(record_mujoco(model, coeffs, times=ours.t))
        n = min(p.frames for p in episodes)
        with VideoWriter(out, fps) as w, tqdm(total=n, desc="render", unit="frame", disable=not progress) as bar:
            for img in episode_frames(painter, episodes, camera, title=title):
                w.append(img)
                bar.update()
        return {"path": out, "frames": n, "fps": fps, "size": (width * len(episodes), height),
                "backend": painter.backend, "seconds": float(ours.t[n - 1]),
                "episodes": [{"engine": p.label, "fitness": p.fitness, "distance": float(distance(model, p)[-1]),
                              "fallen": p.fallen, "diverged": p.diverged} for p in episodes]}
