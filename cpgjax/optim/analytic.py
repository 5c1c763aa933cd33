"""Cheap *analytic* problems with a known optimum (not part of the thesis).

Used by the tests and by the CLI demo models ``analytic:sphere:G`` and
``analytic:diverging:G`` (:func:`analytic_problem`): the GA and the baselines run on them
with no simulator involved.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.episode.cpg import sinusoid_genome
from cpgjax.optim.problem import Problem


def default_optimum(n_genes: int) -> np.ndarray:
    """A fixed, irregular point inside the search box (|x| <= 0.5) used by the analytic problems."""
    i = np.arange(n_genes, dtype=np.float64)
    return (0.5 * np.sin(1.7 * i + 0.3)).astype(np.float32)


def _analytic_base(n_genes: int) -> tuple[np.ndarray, dict]:
    """Base genome and genome shape for an analytic problem: CPG-shaped (K = 2) when G % 5 == 0."""
    if n_genes % 5 == 0:
        base = sinusoid_genome(n_genes // 5, 2).astype(np.float32)
        return base, {"n_dof": n_genes // 5, "harmonics": 2}
    return np.zeros(n_genes, np.float32), {"n_dof": n_genes, "harmonics": 0}


def sphere_problem(n_genes: int, optimum: np.ndarray | None = None, scale: float = 0.25,
                   name: str | None = None) -> Problem:
    """``f(g) = 1 - mean((g - opt)^2) / scale``: maximum 1 at ``opt``, negative far from it.

    The negative values far from the optimum exercise the selection's handling of negative
    fitness; ``distance`` (RMS distance to the optimum) is returned as an extra metric.
    """
    opt = default_optimum(n_genes) if optimum is None else np.asarray(optimum, np.float32)
    if opt.shape != (n_genes,):
        raise ValueError(f"optimum must have shape ({n_genes},), got {opt.shape}")
    opt_j = jnp.asarray(opt)

    def evaluate(genomes: jax.Array) -> dict[str, jax.Array]:
        g = jnp.asarray(genomes, jnp.float32)
        msd = jnp.mean(jnp.square(g - opt_j), axis=-1)
        return {"fitness": 1.0 - msd / scale, "diverged": jnp.zeros(g.shape[0], bool),
                "distance": jnp.sqrt(msd)}

    base, shape = _analytic_base(n_genes)
    meta = {"model_path": name or f"analytic:sphere:{n_genes}", "model_text": "", "scale": scale,
            "optimum": " ".join(f"{v:.6f}" for v in opt), **shape}
    return Problem(name=name or f"analytic:sphere:{n_genes}", n_genes=n_genes, base_genome=base,
                   evaluate=evaluate, meta=meta)


def diverging_problem(n_genes: int, optimum: np.ndarray | None = None, threshold: float = 0.6,
                      scale: float = 0.25, name: str | None = None) -> Problem:
    """The sphere problem, but a genome with any ``|gene| > threshold`` "diverges".

    Diverged individuals get ``fitness = NaN`` and ``diverged = True``, like a simulation that
    blew up; used to test that NaN never propagates into the GA.
    """
    inner = sphere_problem(n_genes, optimum, scale)

    def evaluate(genomes: jax.Array) -> dict[str, jax.Array]:
        out = inner.evaluate(genomes)
        bad = jnp.any(jnp.abs(genomes) > threshold, axis=-1)
        return {**out, "fitness": jnp.where(bad, jnp.nan, out["fitness"]), "diverged": bad}

    nm = name or f"analytic:diverging:{n_genes}"
    return Problem(name=nm, n_genes=n_genes, base_genome=inner.base_genome, evaluate=evaluate,
                   meta={**inner.meta, "model_path": nm, "threshold": threshold})


ANALYTIC = {"sphere": sphere_problem, "diverging": diverging_problem}


@functools.lru_cache(maxsize=32)
def analytic_problem(spec: str) -> Problem:
    """Parse ``analytic:KIND:G`` (KIND in ``sphere``, ``diverging``) — a test/demo model for the CLI.

    ``cpgjax evolve analytic:sphere:40`` runs the GA on :func:`sphere_problem` with 40 genes
    (8 "joints" x 5 coefficients); no simulator is involved.  Cached: the same spec gives the
    same object (so repeated runs in one process reuse the compiled generation).
    """
    parts = spec.split(":")
    if len(parts) != 3 or parts[0] != "analytic" or parts[1] not in ANALYTIC:
        raise ValueError(f"bad analytic model {spec!r}: expected analytic:{{{'|'.join(ANALYTIC)}}}:G")
    try:
        n = int(parts[2])
    except ValueError:
        raise ValueError(f"bad analytic model {spec!r}: G must be an integer") from None
    if n < 1:
        raise ValueError(f"bad analytic model {spec!r}: G must be >= 1")
    return ANALYTIC[parts[1]](n, name=spec)
