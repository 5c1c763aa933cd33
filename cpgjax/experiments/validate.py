"""A run's champion chosen by validation: its top candidates re-scored over fresh perturbed episodes.

A run's best (:meth:`cpgjax.io.results.Run.best`) is the highest score any individual drew in one
generation's evaluation.  Under the robust evaluation that score is itself the mean of a few perturbed
episodes (4 by default), so the best of 3000 such draws is the luckiest draw as much as the best
controller: the winner's curse of a noisy fitness (docs/evolution.md, *Choosing a run's champion*).
Validation takes the run's ``candidates`` best distinct genomes (by the score recorded for them), scores
every one over ``episodes`` new perturbed episodes and keeps the one with the highest mean.

Every candidate meets the same episodes (common random numbers: the same pose, robot, foot and gene jitter
draws for each), so candidates are compared with each other and not with their luck.  The episodes are
the run's own robust evaluation (its ``--perturb`` ranges and fall rule) with ``episodes`` replicas; a
run evolved with the thesis's single episode is validated under :data:`THESIS_RUNS`, the robust
evaluation the README recommends.  The draws come from ``seed`` alone, so a validation is reproducible.

What it is for (docs/evolution.md): an honest score of the controller a run hands over, in this simulator.  It
is not a transfer fix: the champions walked no better in MuJoCo than the runs' bests (docs/results/transfer.md),
so ``cpgjax best`` and ``transfer`` keep the best by default.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.crosscheck.transfer import run_setting
from cpgjax.episode.perturb import Perturbations
from cpgjax.episode.policy import Family, family_from_meta
from cpgjax.io.results import ResultsError, Run
from cpgjax.io.wl import parse_wl
from cpgjax.optim.factory import robust_problem
from cpgjax.sim.model import build_model

# the perturbations a thesis-evaluation run is validated under: the README's recommended robust evaluation
THESIS_RUNS = {"fall_survival": True, "bristle": 3.0}
VALIDATION_STREAM = 0x7A11  # folded into the seed's key: validation draws are not any generation's draws


@dataclass(frozen=True)
class Validation:
    """How a champion is validated (defaults: 64 candidates x 16 episodes, about 1/12 of a thesis-budget
    robust run's 3000 x 4 episodes)."""

    candidates: int = 64
    episodes: int = 16
    seed: int = 0
    perturb: tuple = ()      # (key, value) ranges that replace the run's own (``--validate-perturb``)

    @property
    def stricter(self) -> str:
        """``", key=value, ..."`` of the ranges that replace the run's own (empty without), for a summary line."""
        return "".join(f", {k}={x}" for k, x in self.perturb)

    def __post_init__(self) -> None:
        for f in ("candidates", "episodes"):
            if int(getattr(self, f)) < 1:
                raise ValueError(f"validation {f} must be >= 1, got {getattr(self, f)}")


@dataclass
class Champion:
    """The validated pick of a run."""

    generation: int
    index: int
    recorded: float          # the score the run recorded for it
    score: float             # its mean over the validation episodes
    genome: np.ndarray
    scores: np.ndarray       # every candidate's validation score, best recorded first (scores[0]: the run's best)
    recorded_scores: np.ndarray  # the scores the run recorded for them, in the same order
    perturbations: dict      # the validation episodes' ranges

    def to_dict(self) -> dict:
        return {"generation": self.generation, "index": self.index, "recorded": self.recorded, "score": self.score,
                "candidates": len(self.scores), "score_of_run_best": float(self.scores[0]),
                "perturbations": self.perturbations}


def candidates(run: Run, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ``k`` best distinct valid genomes of a run by recorded score: ``(where [k, 2] (generation, index),
    genomes [k, G], recorded [k])``, best first (the first is :meth:`Run.best`'s)."""
    v = run.valid_fitness()
    flat = v.ravel()
    genomes = run.genomes.reshape(-1, run.genomes.shape[-1])
    order = np.argsort(-np.where(np.isfinite(flat), flat, -np.inf), kind="stable")
    seen: set[bytes] = set()
    picked: list[int] = []
    for i in order:
        if not np.isfinite(flat[i]):
            break
        b = genomes[i].tobytes()
        if b not in seen:
            seen.add(b)
            picked.append(int(i))
            if len(picked) == k:
                break
    if not picked:
        raise ResultsError(f"{run.path}: no valid (finite, not diverged) individual")
    where = np.stack(np.unravel_index(np.asarray(picked), v.shape), axis=1)
    return where, genomes[picked], flat[picked]


def perturbations(run: Run, episodes: int, overrides=()) -> Perturbations:
    """The validation episodes of a run: its own robust evaluation (or :data:`THESIS_RUNS`), ``episodes`` replicas,
    with the ranges ``overrides`` (``(key, value)`` pairs, ``preset=NAME`` among them) in place of the run's.  The
    score is their mean: a run's ``worst`` (its evolution's score by its worst episodes) is not carried over."""
    stored = run.meta.get("perturbations") if str(run.meta.get("evaluation", "thesis")) == "robust" else None
    ranges = {k: v for k, v in stored.items() if k != "worst"} if stored else dict(THESIS_RUNS)
    extra = dict(overrides)
    if "preset" in extra:
        from cpgjax.episode.perturb import PRESETS

        ranges |= PRESETS[extra.pop("preset")]
    ranges |= extra
    fields = {f.name for f in dataclasses.fields(Perturbations)}
    return Perturbations(**{k: v for k, v in ranges.items() if k in fields} | {"replicas": int(episodes)})


@functools.lru_cache(maxsize=8)
def _program(text: str, path: str, terrain, delta: float, p: Perturbations, pipeline: str = "springs",
             family: Family | None = None):
    """The model and one jitted robust evaluation per model and validation, whatever the episode's length (its
    length is an argument: a sweep's runs share one compilation, however long their episodes)."""
    model = build_model(parse_wl(text, path), terrain=terrain, pipeline=pipeline)
    return model, jax.jit(robust_problem(path, model, p, T=float(model.episode.time_max), delta=delta,
                                         family=family).evaluate)


def _scorer(text: str, path: str, terrain, T: float, delta: float, p: Perturbations, pipeline: str = "springs",
            family: Family | None = None):
    """``score(genomes, keys)``: the validation's robust evaluation of episodes of ``T`` s (:func:`_program`'s)."""
    model, fn = _program(text, path, terrain, delta, p, pipeline, family)
    length = robust_problem(path, model, p, T=T, delta=delta, family=family).length
    return lambda genomes, keys: fn(genomes, keys, length)


def validate(run: Run, v: Validation = Validation(), pipeline: str | None = None) -> Champion:
    """Re-score the run's ``v.candidates`` best distinct genomes over ``v.episodes`` common perturbed episodes.

    The model is the run's stored text on the run's physics pipeline (:attr:`Run.pipeline`) unless ``pipeline``
    names another."""
    text = str(run.meta.get("model_text", ""))
    if not text:
        raise ResultsError(f"{run.path}: the run holds no model (an analytic problem?): nothing to validate")
    _, time, terrain = run_setting(run)
    p = perturbations(run, v.episodes, v.perturb)
    if not time:
        raise ResultsError(f"{run.path}: the run records no episode length")
    where, genomes, recorded = candidates(run, v.candidates)
    score = _scorer(text, str(run.meta.get("model_path", run.path)), terrain, float(time),
                    float(run.meta.get("delta", 8.0)), p, pipeline or run.pipeline, family_from_meta(run.meta))
    key = jax.random.fold_in(jax.random.key(v.seed), VALIDATION_STREAM)
    keys = jnp.repeat(key[None], len(genomes), axis=0)     # common random numbers: the same episodes for each
    scores = np.asarray(score(jnp.asarray(genomes, jnp.float32), keys)["fitness"], np.float64)
    best = int(np.nanargmax(np.where(np.isfinite(scores), scores, -np.inf)))
    return Champion(generation=int(where[best, 0]), index=int(where[best, 1]), recorded=float(recorded[best]),
                    score=float(scores[best]), genome=np.asarray(genomes[best]), scores=scores,
                    recorded_scores=np.asarray(recorded, np.float64), perturbations=p.to_dict())
