"""What a video draws, frame by frame: the body poses of one episode (:class:`Poses`).

- :func:`record_ours`: our simulator's episode, recorded by :func:`cpgjax.episode.rollout.rollout`
  with the probe ``Record`` at the video's frame rate (``log_rate=fps``): the exact poses we simulated,
  one sample per frame, nothing re-simulated or interpolated.  The caption's fitness is the
  episode's as :func:`cpgjax.episode.batch.simulate` scores it (``cpgjax simulate`` prints the same);
  when the frame period divides the episode into the same integration steps, the recorded rollout
  *is* that evaluation, otherwise the evaluation is run once more beside it.
- :func:`record_mujoco`: the same controller in MuJoCo C (:func:`cpgjax.crosscheck.engines.mujoco_run`),
  its ``qpos`` turned into body poses by ``mj_kinematics`` on the exported model and sampled at the
  same times.
- :func:`load_run`: a run file's model (the ``.wl`` text stored in it), its best controller (of the
  whole run or of one generation) and the episode length and terrain it was evolved with.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from cpgjax.sim.rotation import quat_to_mat_np


@dataclass
class Poses:
    """Body frames (the `.wl` frames, not the CMs) of an episode at the video's frames.

    t [F] s; pos [F, nb, 3] m; quat [F, nb, 4] (w, x, y, z); ``margin``: a contact vertex this
    close to the terrain (m) is drawn as touching (0 for our penalty contact: touching means
    below the terrain; 0.5 mm for MuJoCo's, whose contact spheres rest with their lowest point where the
    vertex would: the exported ground lies a sphere's radius lower).
    """

    t: np.ndarray
    pos: np.ndarray
    quat: np.ndarray
    label: str
    fitness: float
    margin: float = 0.0
    fallen: bool = False
    diverged: bool = False

    @property
    def frames(self) -> int:
        return len(self.t)


def rotations(quat: np.ndarray) -> np.ndarray:
    """[..., 3, 3] rotation matrices of quaternions [..., 4]."""
    R = quat_to_mat_np(np.moveaxis(np.asarray(quat, float), -1, 0))   # [3, 3, ...]
    return np.moveaxis(R, (0, 1), (-2, -1))


def cm_positions(model, poses: Poses) -> np.ndarray:
    """[F, nb, 3] centres of mass."""
    return poses.pos + np.einsum("fbij,jb->fbi", rotations(poses.quat), model.cm_local)


def distance(model, poses: Poses, forward: int = 1) -> np.ndarray:
    """[F] the tracked body's CM along the forward axis (y) since the first frame, m."""
    y = cm_positions(model, poses)[:, model.track, forward]
    return y - y[0]


def contact_points(model, poses: Poses) -> np.ndarray:
    """[F, nc, 3] world positions of the contact vertices."""
    pt = model.ct_pt
    b = model.pt_body[pt]
    local = model.pt_local[:, pt] + model.cm_local[:, b]            # [3, nc] in the body frames
    R = rotations(poses.quat)[:, b]                                  # [F, nc, 3, 3]
    return poses.pos[:, b] + np.einsum("fcij,jc->fci", R, local)


def touching(model, poses: Poses, points: np.ndarray | None = None) -> np.ndarray:
    """[F, nc] bool: the contact vertex is on (or in) the terrain."""
    p = contact_points(model, poses) if points is None else points
    if p.size == 0:
        return np.zeros(p.shape[:2], bool)
    zg = np.asarray(model.terrain.height_np(p[..., 0], p[..., 1]), float)
    return p[..., 2] - zg < poses.margin


def frames_from_cm(model, x: np.ndarray, q: np.ndarray):
    """Body frames from CM positions x [F, 3, nb] and orientations q [F, 4, nb] (the rollout's layout)."""
    quat = np.moveaxis(q, 1, 2)                                       # [F, nb, 4]
    cm = np.moveaxis(x, 1, 2)                                         # [F, nb, 3]
    pos = cm - np.einsum("fbij,jb->fbi", rotations(quat), model.cm_local)
    return pos, quat


def _one(model, controller):
    """One controller: CPG coefficients [n_ctrl, 2K+1] float32, or a one-robot closed loop (as it is)."""
    from cpgjax.episode.policy import is_closed

    if is_closed(controller):
        return controller
    return np.asarray(controller, np.float32).reshape(model.n_ctrl, model.n_coeff)


def record_ours(model, coeffs, *, time: float | None = None, fps: float = 30.0, delta: float | None = None) -> Poses:
    """Our simulator's episode of one controller [n_ctrl, 2K+1], one recorded sample per video frame.

    Frames come every ``round(1 / (fps dt))`` integration steps (the rollout's ``log_rate``).
    """
    import jax
    import jax.numpy as jnp

    from cpgjax.episode.batch import LANES, simulate
    from cpgjax.episode.fitness import DEFAULT_DELTA
    from cpgjax.episode.probes import Record
    from cpgjax.episode.rollout import rollout, schedule

    delta = DEFAULT_DELTA if delta is None else delta
    c = _one(model, coeffs)
    C = jax.tree.map(lambda a: np.repeat(a[None], LANES, 0), c)   # one whole SIMD vector of robots, as simulate runs it
    T = model.episode.time_max if time is None else float(time)
    f = jax.jit(lambda cc: rollout(model, jax.tree.map(lambda a: jnp.moveaxis(a, 0, -1), cc), time=T, delta=delta,
                                   probes=(Record(),), log_rate=fps))
    out = jax.tree.map(lambda a: np.asarray(a), f(C))
    traj = out["traj"]
    pos, quat = frames_from_cm(model, traj["x"][..., 0].astype(float), traj["q"][..., 0].astype(float))
    inner_v, outer_v = schedule(model, T, fps)
    inner_e, outer_e = schedule(model, T)
    if inner_v * outer_v == inner_e * outer_e:      # the same integration steps: this is the evaluation
        res = {k: out[k][0] for k in ("fitness", "fallen", "diverged")}
    else:
        res = simulate(model, c, time=T, delta=delta)
    return Poses(t=np.asarray(traj["t"], float), pos=pos, quat=quat, label="ours",
                 fitness=float(res["fitness"]), margin=0.0, fallen=bool(res["fallen"]),
                 diverged=bool(res["diverged"]))


def record_mujoco(model, coeffs, *, times: np.ndarray, delta: float | None = None) -> Poses:
    """The same controller in MuJoCo C (the exported model), its body frames at ``times`` [F] s."""
    import jax
    import mujoco

    from cpgjax.crosscheck.engines import mujoco_run
    from cpgjax.crosscheck.mjcf import load
    from cpgjax.episode.fitness import DEFAULT_DELTA

    delta = DEFAULT_DELTA if delta is None else delta
    mj = load(model)
    c = jax.tree.map(lambda a: a[None], _one(model, coeffs))
    T = float(np.max(times))
    metrics, qpos, _ = mujoco_run(model, c, time=T, delta=delta, mj=mj, nthread=1)
    idx = np.clip(np.rint(np.asarray(times) / mj.opt.timestep).astype(int), 0, qpos.shape[1] - 1)
    bids = [mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, n) for n in model.body_names]
    d = mujoco.MjData(mj)
    pos = np.zeros((len(idx), model.nb, 3))
    quat = np.zeros((len(idx), model.nb, 4))
    for k, i in enumerate(idx):
        d.qpos[:] = qpos[0, i]
        mujoco.mj_kinematics(mj, d)
        pos[k] = d.xpos[bids]
        quat[k] = d.xquat[bids]
    get = lambda key, default: np.asarray(metrics.get(key, default)).ravel()[0]  # noqa: E731
    return Poses(t=np.asarray(times, float), pos=pos, quat=quat, label="MuJoCo C",
                 fitness=float(get("fitness", np.nan)), margin=5e-4,
                 fallen=bool(get("fallen", False)), diverged=bool(get("diverged", False)))


def load_run(path: str, generation: int | None = None, *, terrain: str | None = None, pipeline: str | None = None):
    """(model, controller, time, label) of a run file's best controller (coefficients [n_ctrl, 2K+1], or a one-robot
    :class:`~cpgjax.episode.policy.ClosedLoop` for a closed-loop run).

    ``generation``: the best of that generation (negative counts from the end) instead of the whole
    run's.  The model is the `.wl` text stored in the run (not the file on disk, which may have
    changed), on the terrain, episode length and physics pipeline the run was evolved with unless ``terrain``
    or ``pipeline`` is given.
    """
    from cpgjax.io.results import read_run
    from cpgjax.io.wl import parse_wl
    from cpgjax.render import RenderError
    from cpgjax.sim.model import build_model

    run = read_run(path)
    if generation is None:
        gen, idx, fit, genome = run.best()
    else:
        v = run.valid_fitness()
        g = generation + run.completed if generation < 0 else generation
        if not 0 <= g < v.shape[0]:
            raise RenderError(f"{path}: --generation {generation}: the run has generations 0..{v.shape[0] - 1}")
        if not np.isfinite(v[g]).any():
            raise RenderError(f"{path}: generation {g} has no valid (finite, not diverged) individual")
        gen, idx = g, int(np.nanargmax(v[g]))
        fit, genome = float(v[g, idx]), run.genomes[g, idx]
    text = str(run.meta.get("model_text", ""))
    if not text:
        raise RenderError(f"{path}: the run holds no model (an analytic problem?): nothing to render")
    cli = json.loads(run.meta.get("cli_problem_args", "{}") or "{}")
    model = build_model(parse_wl(text, str(run.meta.get("model_path", path))),
                        terrain=terrain if terrain is not None else cli.get("terrain"),
                        pipeline=pipeline or run.pipeline)
    time = cli.get("time") or run.meta.get("time") or model.episode.time_max
    import jax

    from cpgjax.episode.policy import family_from_meta, from_genomes

    coeffs = jax.tree.map(lambda a: a[0], from_genomes(family_from_meta(run.meta), model,
                                                        np.asarray(genome, np.float32)[None]))
    return model, coeffs, float(time), f"generation {gen}, #{idx} (GA fitness {fit:+.4f})"
