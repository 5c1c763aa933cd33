"""The problem of a repertoire: the thesis's fitness and a behaviour descriptor, on an intact or damaged robot.

A fall (the body tilted past 60 degrees, :data:`cpgjax.episode.rollout.FALL_TILT`) ends the episode's fitness
(the rollout's ``fall_ends``) and is flagged in the metric ``down``, which MAP-Elites reads as "not a gait"
(``meta["fall_metric"]``; :func:`cpgjax.optim.mapelites.mapelites_algorithm`).

:func:`behaviour_problem` is :func:`cpgjax.optim.factory.wl_problem`'s episode (eq. 4.5-4.6, one exact
episode) with the rollout's descriptors switched on (:mod:`cpgjax.episode.descriptors`): its ``evaluate``
returns, besides the fitness and the usual metrics, one ``[N]`` metric per descriptor dimension
(``duty_AR`` ... or ``speed``, ``turn``) and always all of them (``duty_*``, ``heading_speed``, ``turn``),
so that any archive can be re-read under another descriptor.  ``damage`` (:mod:`cpgjax.episode.damage`)
builds the damaged robot; the genome the search proposes is the same, the damage stays inside.
"""

from __future__ import annotations

import json

import jax.numpy as jnp
import numpy as np

from cpgjax.episode import damage as dmg
from cpgjax.episode import descriptors as bd
from cpgjax.episode.batch import evaluate
from cpgjax.episode.fitness import DEFAULT_DELTA
from cpgjax.episode.probes import Descriptors
from cpgjax.episode.rollout import episode_length
from cpgjax.io.wl import load_wl
from cpgjax.optim.factory import base_genome
from cpgjax.optim.problem import Problem
from cpgjax.sim.model import build_model


def descriptor_metrics(model, descriptor: str) -> tuple[str, ...]:
    """The metric names of a descriptor's dimensions for ``model`` (``speed`` is the heading speed)."""
    names = bd.names(model, descriptor)
    return tuple("heading_speed" if n == "speed" else n for n in names)


def behaviour_problem(model_path: str, *, descriptor: str = "duty", time: float | None = None,
                      terrain: str | None = None, delta: float = DEFAULT_DELTA, pipeline: str | None = None,
                      damage: str | None = None, chunk: int = 256) -> Problem:
    """The Problem of a repertoire on the `.wl` model at ``model_path`` (see the module docstring).

    ``meta`` records the episode's settings (as :func:`~cpgjax.optim.factory.wl_problem`'s), the
    descriptor, its metric names (``descriptor_metrics``, JSON) and the damage (``none``: intact).
    """
    if descriptor not in bd.DESCRIPTORS:
        raise ValueError(f"unknown descriptor {descriptor!r}: expected one of {', '.join(bd.DESCRIPTORS)}")
    desc = load_wl(model_path)
    intact = build_model(desc, terrain=terrain, pipeline=pipeline)
    damages = dmg.parse(damage, intact)
    model = build_model(dmg.damaged_description(desc, intact, damages), terrain=terrain, pipeline=pipeline) \
        if damages else intact
    mask = jnp.asarray(dmg.controller_mask(intact, damages))
    n_ctrl, n_coeff = model.n_ctrl, model.n_coeff
    T = model.episode.time_max if time is None else float(time)
    leg_names = bd.legs(intact)[0]
    dims = descriptor_metrics(intact, descriptor)

    episode = episode_length(model, T)

    def evaluate_genomes(genomes, length=episode):
        g = jnp.asarray(genomes, jnp.float32).reshape(-1, n_ctrl, n_coeff)
        if damages:
            g = g * mask
        r = evaluate(model, g, length=length, delta=delta, chunk=chunk, probes=(Descriptors(),), fall_ends=True)
        out = {k: r[k] for k in ("fitness", "diverged", "distance", "speed", "tilt", "fallen", "down")}
        for i, n in enumerate(leg_names):
            out[f"duty_{n}"] = r["duty"][i]
        out["heading_speed"], out["turn"] = r["heading_speed"], r["turn"]
        return out

    meta = {"model_path": str(model_path), "model_text": desc.text, "time": T, "terrain": model.terrain.spec,
            "delta": float(delta), "dt": model.dt, "pipeline": model.pipeline, "n_dof": n_ctrl,
            "harmonics": model.episode.harmonics, "frequency": model.episode.frequency, "evaluation": "thesis",
            "descriptor": descriptor, "descriptor_metrics": json.dumps(list(dims)),
            "legs": json.dumps(list(leg_names)), "damage": dmg.describe(damages), "fall_metric": "down",
            "cli_problem_args": json.dumps({"time": time, "terrain": terrain, "delta": delta,
                                            "pipeline": pipeline, "descriptor": descriptor, "damage": damage})}
    return Problem(name=str(model_path), n_genes=model.n_genes, base_genome=np.asarray(base_genome(intact)),
                   evaluate=evaluate_genomes, meta=meta, length=episode)

