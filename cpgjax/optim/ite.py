"""Intelligent Trial and Error (Cully, Clune, Tarapore & Mouret, Nature 2015): Bayesian optimisation over a
repertoire, with a small Gaussian process (beyond the thesis).

After damage, the robot tries gaits of its repertoire one at a time and sees only each trial's fitness.
A Gaussian process over the behaviour descriptors (normalised to the grid's bounds, so every dimension
spans [0, 1]) models the damaged robot's fitness, with the repertoire's fitness as its **prior mean**
``P(x)`` (what the intact robot scored), Cully's M-BOA:

- kernel: Matérn 5/2, ``k(x, x') = s2 (1 + sqrt5 d/rho + 5 d^2 / (3 rho^2)) exp(-sqrt5 d / rho)``,
  ``d = |x - x'|``, with ``s2`` the variance of the repertoire's fitness (the scale of what is modelled;
  the observation noise is ``noise s2``);
- posterior after trials ``chi_1..t`` with observations ``y``:
  ``mu(x) = P(x) + k(x)^T (K + noise s2 I)^-1 (y - P(chi))`` and
  ``sigma^2(x) = k(x, x) - k(x)^T (K + noise s2 I)^-1 k(x)`` (:func:`posterior`; Rasmussen & Williams
  2006, eq. 2.25-2.26, with a prior mean);
- next trial: the untried elite maximising ``mu + kappa sigma`` (upper confidence bound);
- stop once the best trial reaches ``alpha`` times the best upper confidence bound ``mu + stop_z sigma``
  over the elites, or ``alpha`` times the repertoire's best fitness (the intact robot's best: damage is not
  expected to do better), whichever is lower (or after ``trials`` trials): once no elite is, by the GP,
  plausibly (``stop_z`` standard deviations) better than ``1 / alpha`` times the best trial.
  ``stop_z = 0`` is Cully's rule (the best posterior mean), which stops too early on our repertoires: the
  prior mean is the intact robot's fitness, one or two disappointing trials pull the mean of every elite
  near them down, and the elites of a small repertoire all lie near each other (where both rules stop, over
  the damage x repertoire cases: docs/results/repertoire.md).

``offset`` (off by default): the prior mean is ``P(x) + c`` with ``c`` one unknown constant under a flat prior,
estimated from the trials with the GP (Rasmussen & Williams 2006, section 2.7, eq. 2.42; :func:`posterior`).
Cully's prior must explain a damage that lowers *every* gait as a residual ``y - P`` that is only spread
over the tried elites' neighbours (the kernel's length scale), so after a few disappointing trials the elites
far from them keep their intact fitness as prediction and the search goes to them, whatever their intact
fitness; with the offset the common drop is learnt as one shift and the intact ranking (plus the local
residuals) leads.  What it brings, damage by damage, and where its stopping rule stops: docs/results/repertoire.md
(damage recovery at full scale).

Defaults are Cully's (rho 0.4, kappa 0.05, alpha 0.9, noise 1e-3) but for ``stop_z`` (2; Cully's: 0).
A Gaussian process of twenty points over a few thousand elites is a few lines of linear algebra (a
Cholesky factor, ``scipy.linalg``); no GP library is pinned with the project (docs/repertoire.md says
what was measured of QDax).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve

# The spaces IT&E's GP may run in (cpgjax.experiments.adapt.search_space: the descriptor, Cully et al.'s; the
# elites' genomes; both); here, where the CLI reads them without importing the experiment.
SPACES = ("descriptor", "genome", "both")


@dataclass(frozen=True)
class ITEConfig:
    """Settings of one adaptation (Cully et al.'s defaults)."""

    trials: int = 20
    alpha: float = 0.9
    kappa: float = 0.05
    rho: float = 0.4
    noise: float = 1e-3
    stop_z: float = 2.0
    offset: bool = False

    def __post_init__(self) -> None:
        if self.trials < 1:
            raise ValueError(f"trials must be >= 1, got {self.trials}")
        if not 0 <= self.alpha <= 1:
            raise ValueError(f"alpha must be in [0, 1], got {self.alpha}")
        for k in ("rho", "noise"):
            v = getattr(self, k)
            if not (v > 0 and math.isfinite(v)):
                raise ValueError(f"{k} must be > 0, got {v}")
        for k in ("kappa", "stop_z"):
            v = getattr(self, k)
            if not (v >= 0 and math.isfinite(v)):
                raise ValueError(f"{k} must be >= 0, got {v}")


def matern52(a, b, rho: float, variance: float = 1.0) -> np.ndarray:
    """Matérn 5/2 kernel matrix [len(a), len(b)] between points a [n, D] and b [m, D]."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    d = np.sqrt(np.maximum(((a[:, None, :] - b[None, :, :]) ** 2).sum(-1), 0.0)) / rho
    return variance * (1.0 + math.sqrt(5.0) * d + 5.0 / 3.0 * d * d) * np.exp(-math.sqrt(5.0) * d)


def posterior(x, prior, xs, ys, prior_s, rho: float, variance: float, noise: float, *, offset: bool = False):
    """GP posterior mean and variance [n] at points x [n, D] with prior mean ``prior`` [n] there, given
    observations ``ys`` [t] at ``xs`` [t, D] whose prior means are ``prior_s`` [t] (module docstring).

    ``offset``: the prior mean is ``prior + c`` with ``c`` an unknown constant under a flat prior (Rasmussen &
    Williams 2006, section 2.7, eq. 2.42 with ``B^-1 -> 0``, one basis function ``h = 1``): ``c`` is its
    generalised least-squares estimate ``(1' K^-1 1)^-1 1' K^-1 (y - P(chi))`` and its uncertainty adds
    ``(1 - 1' K^-1 k(x))^2 / (1' K^-1 1)`` to the variance.  Without observations the variance is infinite."""
    prior = np.asarray(prior, np.float64)
    if len(ys) == 0:
        return prior.copy(), np.full(prior.shape, np.inf if offset else variance)
    K = matern52(xs, xs, rho, variance) + noise * variance * np.eye(len(ys))
    c = cho_factor(K, lower=True)
    k = matern52(x, xs, rho, variance)                         # [n, t]
    r = np.asarray(ys, np.float64) - np.asarray(prior_s, np.float64)
    Kik = cho_solve(c, k.T)                                    # [t, n]
    var = variance - np.einsum("nt,tn->n", k, Kik)
    if offset:
        Ki1 = cho_solve(c, np.ones(len(ys)))
        a = float(Ki1.sum())                                   # 1' K^-1 1 > 0
        beta = float(Ki1 @ r) / a                              # the offset's estimate
        r = r - beta
        prior = prior + beta
        var = var + (1.0 - Ki1 @ k.T) ** 2 / a
    mu = prior + k @ cho_solve(c, r)
    return mu, np.maximum(var, 0.0)


def ite(desc, prior, trial: Callable[[int], float], cfg: ITEConfig = ITEConfig(), *, stop: bool = True) -> dict:
    """Run Intelligent Trial and Error over the elites: ``desc`` [C, D] their normalised descriptors,
    ``prior`` [C] their fitness in the repertoire, ``trial(i)`` the damaged robot's fitness with elite ``i``.
    ``stop=False``: no stopping rule (``cfg.trials`` trials, or until every elite is tried).

    Returns ``{"trials": [{"index", "predicted", "fitness"}...], "best_index", "best_fitness", "stop"}``.
    """
    desc, prior = np.asarray(desc, np.float64), np.asarray(prior, np.float64)
    s2 = float(np.var(prior)) if prior.size > 1 and np.var(prior) > 0 else 1.0
    tried: list[int] = []
    ys: list[float] = []
    out: list[dict] = []
    reason = f"{cfg.trials} trials"
    top = float(np.max(prior)) if prior.size else 0.0
    why = (f"best trial >= {cfg.alpha:g} x best prediction" if cfg.stop_z == 0 else
           f"best trial >= {cfg.alpha:g} x min(best prediction + {cfg.stop_z:g} sd, the repertoire's best)")

    def done(mu, var) -> bool:
        bound = float(np.max(mu + cfg.stop_z * np.sqrt(var)))
        if cfg.stop_z > 0:
            bound = min(bound, top)             # no elite is expected above what the intact robot's best did
        return bool(stop and ys and max(ys) >= cfg.alpha * bound)

    for _ in range(cfg.trials):
        mu, var = posterior(desc, prior, desc[tried], ys, prior[tried], cfg.rho, s2, cfg.noise, offset=cfg.offset)
        if done(mu, var):
            reason = why
            break
        ucb = mu + cfg.kappa * np.sqrt(var) if np.isfinite(var).all() else mu.copy()   # offset, no trial: P
        ucb[tried] = -np.inf
        if not np.isfinite(ucb).any():
            reason = "every elite tried"
            break
        i = int(np.argmax(ucb))
        y = float(trial(i))
        if not math.isfinite(y):
            y = float(np.min(prior)) if prior.size else 0.0     # a diverged trial: as bad as the worst elite
        tried.append(i)
        ys.append(y)
        out.append({"index": i, "predicted": float(mu[i]), "fitness": y})
    else:
        mu, var = posterior(desc, prior, desc[tried], ys, prior[tried], cfg.rho, s2, cfg.noise, offset=cfg.offset)
        if done(mu, var):
            reason = why
    b = int(np.argmax(ys))
    return {"trials": out, "best_index": out[b]["index"], "best_fitness": ys[b], "stop": reason}
