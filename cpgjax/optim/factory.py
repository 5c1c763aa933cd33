"""The one problem factory: a `.wl` model (the simulator, eq. 4.5-4.6) or an analytic test problem.

``make_problem(MODEL, ...)`` is what ``cpgjax evolve``, ``search`` and ``sweep`` all call:
MODEL is a `.wl` path or ``analytic:KIND:G`` (:mod:`cpgjax.optim.analytic`).  The settings
given are recorded in the problem's meta (``cli_problem_args``) so that a run can be resumed
with exactly the problem it was made with.
"""

from __future__ import annotations

import dataclasses
import json
import math

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.episode import steering
from cpgjax.episode.batch import LANES, evaluate
from cpgjax.episode.cpg import GENE_BOX, sinusoid_genome
from cpgjax.episode.descriptors import legs
from cpgjax.episode.fitness import DEFAULT_DELTA
from cpgjax.episode.mirror import MirrorError
from cpgjax.episode.perturb import (
    Perturbations,
    check_controller,
    commands,
    draw,
    noise_key,
    roughened,
    touch_thresholds,
)
from cpgjax.episode.policy import Family, from_control, from_genomes, parse_controller, to_genome, widen
from cpgjax.episode.policy import base_genome as policy_base
from cpgjax.episode.rollout import episode_length, schedule
from cpgjax.io.wl import load_model
from cpgjax.optim.analytic import analytic_problem
from cpgjax.optim.problem import Problem

EVALUATIONS = ("thesis", "robust")


def make_problem(model: str, *, time: float | None = None, terrain: str | None = None,
                 delta: float | None = None, replicas: int | None = None, chunk: int | None = None,
                 evaluation: str | None = None, perturb: dict | None = None, pipeline: str | None = None,
                 start: str | None = None, controller: str | None = None, free: str | None = None) -> Problem:
    """The Problem for MODEL (a `.wl` file or ``analytic:KIND:G``), recording the settings in its meta.

    ``None`` means the default (the model's TimeMax and terrain, delta 8, one episode).  ``chunk``
    is the simulator's chunk (results do not depend on it; a sweep picks one that pads its batch little).
    ``evaluation``: ``"thesis"`` (default: one exact episode, eq. 4.6) or ``"robust"`` (the mean of
    several episodes with fresh perturbations each generation, :mod:`cpgjax.episode.perturb`, whose
    ranges ``perturb`` overrides, e.g. ``{"replicas": 8}``).  ``pipeline``: the physics pipeline
    (``"springs"`` or ``"exact"``, :data:`cpgjax.sim.model.PIPELINES`; None: the model file's ``Pipeline``, else
    springs); the one the model runs on is recorded in the meta (``pipeline``), so that a resume cannot change it.
    ``start``: a `.ctl` controller the search starts from instead of the thesis's sinusoids (the problem's base
    genome; the GA moves each of its genes by its initial spread); recorded in the meta (``start``).
    ``controller``: the controller family (:func:`cpgjax.episode.policy.parse_controller`: ``cpg``, the thesis's
    open-loop CPG, the default; ``pmtg``: the CPG modulated by a feedback policy), recorded in the meta
    (``controller``) when not the CPG.
    ``free``: ``GROUP+GROUP``, the only genes the search may change (:func:`held_genes`); the others keep the
    start's values.  Recorded in the meta (``free``) when given.
    """
    evaluation = evaluation or "thesis"
    if evaluation not in EVALUATIONS:
        raise ValueError(f"evaluation must be one of {', '.join(EVALUATIONS)}, got {evaluation!r}")
    if perturb and evaluation != "robust":
        raise ValueError("perturbation ranges apply to the robust evaluation only (add --evaluation robust)")
    robust = Perturbations.from_settings(perturb) if evaluation == "robust" else None
    family = parse_controller(controller)
    if robust is not None:
        check_controller(robust, family)
    if model.startswith("analytic:"):
        if pipeline is not None:
            raise ValueError(f"{model}: a physics pipeline applies to a simulated model (.wl) only")
        if family is not None:
            raise ValueError(f"{model}: a closed-loop controller needs a simulated model (.wl)")
        problem = analytic_problem(model)
    else:
        kw: dict = {"time": time, "terrain": terrain, "pipeline": pipeline, "family": family}
        for k, v in (("delta", delta), ("replicas", replicas), ("chunk", chunk), ("robust", robust)):
            if v is not None:
                kw[k] = v
        problem = wl_problem(model, **kw)
    if robust is not None and model.startswith("analytic:"):
        raise ValueError(f"{model}: the robust evaluation needs a simulated model (.wl)")
    cli = {"time": time, "terrain": terrain, "delta": delta, "replicas": replicas, "evaluation": evaluation,
           "perturb": perturb or None, "pipeline": pipeline, "start": start}
    if controller is not None:
        cli["controller"] = controller
    if free is not None:
        cli["free"] = free
    meta = {**problem.meta, "cli_problem_args": json.dumps(cli)}
    if start is not None:
        base = start_genome(start, problem)
        meta["start"] = json.dumps({"path": str(start), "genome": [float(v) for v in base]})
        problem = dataclasses.replace(problem, base_genome=base)
    if free is not None:
        held, meta["free"] = held_genes(free, problem, family)
        problem = dataclasses.replace(problem, held=held)
    return dataclasses.replace(problem, meta=meta)


def held_genes(free: str, problem: Problem, family) -> tuple[np.ndarray, str]:
    """([n_genes] bool, the groups as recorded): the genes kept at the start's values when only those of ``free``
    evolve.  ``free``: ``GROUP+GROUP`` of ``cpg`` (the CPG's coefficients) and the groups the controller's policy
    reads (the weights that read them: ``command+steer+turn`` teaches a walker to turn and leaves its gait)."""
    groups = [g.strip().lower() for g in str(free).split("+")]
    if family is None:
        names = ["cpg"]
        labels = np.full(problem.n_genes, "cpg")
    else:
        names = ["cpg", *family.inputs]
        model = load_model(problem.meta["model_path"], pipeline=problem.meta.get("pipeline"))
        labels = family.gene_groups(model)
    bad = [g for g in groups if g not in names]
    if bad or not all(groups) or len(set(groups)) != len(groups):
        raise ValueError(f"--free {free}: the groups are distinct ones of {', '.join(names)} (this run's "
                         f"--controller {family.spec if family else 'cpg'}); got {', '.join(bad) or free!r}")
    held = ~np.isin(labels, groups)
    if held.all() or not held.any():
        raise ValueError(f"--free {free}: " + ("no gene would evolve" if held.all() else
                                               "every gene evolves anyway; leave --free out"))
    return held, "+".join(g for g in names if g in groups)


def start_genome(path: str, problem: Problem) -> np.ndarray:
    """The genome of the `.ctl` controller at ``path`` for ``problem`` (its DOFs and harmonics; clipped to the
    search box, which a hand-written controller may leave)."""
    from cpgjax.io.ctl import read_ctl

    n_dof, harmonics = problem.meta.get("n_dof"), problem.meta.get("harmonics")
    if n_dof is None or harmonics is None:
        raise ValueError(f"--start {path}: a starting controller needs a simulated model (.wl)")
    c = read_ctl(path, n_dof=int(n_dof), harmonics=int(harmonics))
    g = np.asarray(c.coeffs, np.float32).reshape(-1)
    family = parse_controller(problem.meta.get("controller"))
    if family is not None:        # a closed-loop problem: the controller's policy, else a policy of zeros
        model = load_model(problem.meta["model_path"], pipeline=problem.meta.get("pipeline"))
        try:
            if c.policy is not None:     # the same policy, or one reading fewer groups (their weights made 0)
                g = to_genome(widen(from_control(c, model), family, model), model, family)
            else:
                g = policy_base(family, model, g).astype(np.float32)
        except (MirrorError, ValueError) as e:
            raise ValueError(f"--start {path}: {e}; this run's --controller is {family.spec}") from None
    elif c.policy is not None:
        raise ValueError(f"--start {path}: a closed-loop controller; add --controller {c.policy.name}")
    return np.clip(g, problem.lower, problem.upper)


def wl_problem(wl_path: str, *, time: float | None = None, terrain: str | None = None,
                 delta: float = DEFAULT_DELTA, chunk: int = 256, dt: float | None = None,
                 replicas: int = 1, jitter: float = 1e-3, robust: Perturbations | None = None,
                 pipeline: str | None = None, family: Family | None = None):
    """A GA Problem for a `.wl` model: genome = CPG coefficients of every controlled joint (and with a closed-loop
    ``family``, the policy's genes after them: :mod:`cpgjax.episode.policy`).

    ``replicas > 1`` scores each genome as the mean over that many episodes, the first
    with the genome itself and the others with every gene moved by a fixed pseudo-random
    offset of standard deviation ``jitter`` (the same offsets for every genome and every
    generation, so the fitness stays deterministic).  The thesis used one episode
    (``replicas = 1``, the default); evolved gaits can be chaotic, and a single episode
    then rewards lucky controllers (docs/evolution.md, "A noisy fitness").

    ``robust``: each genome is scored as the mean of ``robust.replicas`` episodes with fresh
    perturbations (:mod:`cpgjax.episode.perturb`) drawn from the keys the driver passes; the
    problem is then ``stochastic``.  ``fallen`` is the fraction of its episodes that fell.

    ``pipeline``: the physics pipeline (None: the file's ``Pipeline``, else "springs"); the meta records the
    model's (``pipeline``).
    """
    model = load_model(wl_path, dt=dt, terrain=terrain, pipeline=pipeline)
    n_ctrl = model.n_ctrl
    T = model.episode.time_max if time is None else float(time)
    G = model.n_genes if family is None else family.n_genes(model)

    R = max(int(replicas), 1)
    offsets = np.random.default_rng(12345).normal(0.0, jitter, (R, G)).astype(np.float32)
    offsets[0] = 0.0
    keys = ("fitness", "diverged", "distance", "speed", "tilt", "fallen")

    episode = episode_length(model, T)

    def evaluate_genomes(genomes, length=episode):
        g = jnp.asarray(genomes, jnp.float32)
        n = g.shape[0]
        if R > 1:
            g = jnp.clip(g[:, None, :] + offsets[None], -GENE_BOX, GENE_BOX).reshape(n * R, -1)
        r = evaluate(model, controllers(family, model, g), length=length, delta=delta, chunk=chunk)
        out = {k: r[k] for k in keys}
        if R > 1:
            out = {k: (v.reshape(n, R).any(1) if v.dtype == jnp.bool_ else v.reshape(n, R).mean(1))
                   for k, v in out.items()}
        return out

    if robust is not None:
        if replicas != 1:
            raise ValueError("replicas (fixed jitter offsets) and the robust evaluation cannot be combined; "
                             "the robust evaluation has its own replicas")
        return robust_problem(wl_path, model, robust, T=T, delta=delta, chunk=chunk, family=family)

    desc = model.description
    meta = {
        "model_path": str(wl_path), "model_text": desc.text if desc else "", "time": T,
        "terrain": model.terrain.spec, "delta": float(delta), "dt": model.dt, "pipeline": model.pipeline,
        "n_dof": n_ctrl, "harmonics": model.episode.harmonics, "frequency": model.episode.frequency,
        "evaluation": "thesis", "replicas": R, "jitter": float(jitter),
    } | controller_meta(family)
    base = base_genome(model) if desc else sinusoid_genome(n_ctrl, model.episode.harmonics)
    return Problem(name=str(wl_path), n_genes=G, base_genome=policy_base(family, model, base, symmetrize=True),
                   evaluate=evaluate_genomes, meta=meta, length=episode)


def episode_scores(r: dict, p: Perturbations, steered: bool = False, turn=None) -> dict:
    """An episode's results ``r`` with its fitness as the robust evaluation scores it: the tracking fitness of a
    commanded turning rate (``steered``: :func:`cpgjax.episode.steering.tracking_fitness`, capped at ``p.speed``;
    with ``p.turn_speed`` the cap falls linearly to it as ``turn`` [episodes], the episode's mean ``abs(command)``,
    rises to ``p.command``), not eq. 4.6's; without a command, eq. 4.6's fitness taken up to ``p.speed`` when it is
    set (a gait scored by how surely it reaches that speed, not by how far past it it goes); with ``p.overspeed``
    the speed past the cap costs that many times itself (:func:`cpgjax.episode.steering.capped`); with
    ``p.per_cap`` the steering score is divided by the episode's cap (each episode up to 1); then a fall
    forfeits the episode (``fall_zero``) or scales it by the share of it the robot stayed up (``fall_survival``)."""
    if steered:
        cap = p.speed
        if p.turn_speed > 0:
            cap = p.speed - (p.speed - p.turn_speed) * jnp.minimum(turn / p.command, 1.0)
        r = dict(r, fitness=steering.tracking_fitness(r["heading_fitness"], r["turn_error"], p.command, cap,
                                                      p.overspeed, p.turn_tolerance))
        if p.per_cap:
            r = dict(r, fitness=r["fitness"] / cap)
    elif p.speed > 0:
        r = dict(r, fitness=steering.capped(r["fitness"], p.speed, p.overspeed))
    if p.fall_zero:
        r = dict(r, fitness=jnp.where(r["down"], 0.0, r["fitness"]))
    elif p.fall_survival:
        r = dict(r, fitness=r["fitness"] * r["up"])
    return r


def replica_scores(r: dict, p: Perturbations, n: int, steered: bool = False) -> dict:
    """Each controller's results from its ``p.replicas`` episodes (``r``'s arrays are ``[n * replicas]``, a
    controller's episodes side by side): ``diverged`` if any diverged, the other metrics their means, and the
    fitness the mean of all of them or, with ``p.worst``, of the ``worst`` lowest (a gait scored by its bad luck)."""
    out = {}
    for key in METRICS + (("turn_error",) if steered else ()):
        v = r[key].reshape(n, p.replicas)
        out[key] = v.any(1) if key == "diverged" else v.astype(jnp.float32).mean(1)
    if p.worst:
        out["fitness"] = jnp.sort(r["fitness"].reshape(n, p.replicas), axis=1)[:, : p.worst].mean(1)
    return out


def controllers(family: Family | None, model, g, key=None, steer=None, touch=None):
    """The controllers of genomes ``g`` [N, G] (:func:`cpgjax.episode.policy.from_genomes`), computed apart from the
    simulation (the barrier: the same weights in every program, cf. :func:`robust_problem`)."""
    c = from_genomes(family, model, g, key=key, steer=steer, touch=touch)
    return c if family is None else jax.lax.optimization_barrier(c)


def controller_meta(family: Family | None) -> dict:
    """What a run records of its controller family: nothing for the thesis's CPG (the runs made before it)."""
    return {} if family is None else {"controller": family.spec}


def base_genome(model) -> np.ndarray:
    """The GA's starting controller: one 0.5 Hz sinusoid per joint (Ch. 4.3), amplitude 0.3 rad."""
    return sinusoid_genome(model.n_ctrl, model.episode.harmonics, amplitude=0.3)


METRICS = ("fitness", "diverged", "distance", "speed", "tilt", "fallen")


def robust_problem(wl_path, model, p: Perturbations, *, T: float, delta: float, chunk: int = 256,
                   family: Family | None = None) -> Problem:
    """The robust evaluation of a built ``model`` read from ``wl_path`` (see :func:`wl_problem`)."""
    model = model.replace(terrain=roughened(model.terrain, p.roughness, p.texture))
    n_ctrl, R = model.n_ctrl, p.replicas
    G = model.n_genes if family is None else family.n_genes(model)
    sensing = {} if family is None else {"latency": p.latency, "noise": p.noise}
    lo, hi = -GENE_BOX, GENE_BOX
    check_controller(p, family)     # ranges the controller cannot feel (sensor noise for the CPG, ...) refused
    # the episode's length as data (one program for every length); under a steering schedule with its switch, the
    # switch's share of the episode and their reciprocals, as the host rounds the constants they replace
    episode = episode_length(model, T)
    if p.command > 0:   # the schedule switches at the log sample nearest the episode's middle
        inner, outer = schedule(model, T)
        switch = (outer // 2) * inner * model.dt
        episode = episode_length(model, T, switch=switch)
        episode |= {"turn_first": np.float32(switch), "turn_second": np.float32(T - switch),
                    "per_time": np.float32(1.0) / np.float32(T)}     # the mean command's weights (T: the --time)

    def evaluate_genomes(genomes, keys, length=episode):
        g = jnp.asarray(genomes, jnp.float32)
        n = g.shape[0]
        k = jax.vmap(lambda kk: jax.random.split(kk, R))(keys).reshape(n * R)
        # draw in whole SIMD vectors (see cpgjax.episode.batch.LANES): a robot's perturbations then do
        # not depend on how many robots share the batch (a sweep's run equals the same run made alone)
        pad = -(n * R) % LANES
        k = jnp.concatenate([k, jnp.repeat(k[-1:], pad)]) if pad else k
        var, offsets = draw(model, p, k, G)
        var, offsets = jax.tree.map(lambda a: a[..., : n * R], var), offsets[: n * R]
        g = jnp.clip(jnp.repeat(g, R, axis=0) + offsets, lo, hi)
        # the barrier keeps XLA from fusing (and re-rounding) the draws into the simulation differently
        # in different programs (cf. optim.algorithm.generation_step)
        var, g = jax.lax.optimization_barrier((var, g))
        nk = noise_key(k[: n * R]) if family is not None and p.noise > 0 else None
        steer = None
        if p.command > 0:
            c = commands(k[: n * R], p.command)
            steer = steering.Schedule(c[0], c[1], None, p.command)     # its switch: the length's
        at = touch_thresholds(k[: n * R], len(legs(model)[0]), p.touch) if p.touch > 0 else None
        r = evaluate(model, controllers(family, model, g, nk, steer, at), delta=delta, chunk=chunk, var=var,
                     fall_ends=p.fall_ends or p.fall_zero or p.fall_survival, length=length, **sensing,
                     fall_tilt=math.radians(p.fall_tilt))
        turn = None if steer is None else \
            (length["turn_first"] * jnp.abs(c[0]) + length["turn_second"] * jnp.abs(c[1])) * length["per_time"]
        r = episode_scores(r, p, steered=steer is not None, turn=turn)
        return replica_scores(r, p, n, steered=steer is not None)

    desc = model.description
    meta = {"model_path": str(wl_path), "model_text": desc.text if desc else "", "time": T,
            "terrain": model.terrain.spec, "delta": float(delta), "dt": model.dt, "pipeline": model.pipeline,
            "n_dof": n_ctrl,
            "harmonics": model.episode.harmonics, "frequency": model.episode.frequency, "evaluation": "robust",
            "replicas": R, "perturbations": p.to_dict()} | controller_meta(family)
    base = base_genome(model) if desc else sinusoid_genome(n_ctrl, model.episode.harmonics)
    return Problem(name=str(wl_path), n_genes=G, base_genome=policy_base(family, model, base, symmetrize=True),
                   evaluate=evaluate_genomes, meta=meta, stochastic=True, length=episode)
