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
- stop once the best trial reaches ``alpha`` times the best posterior mean (or after ``trials`` trials).

Defaults are Cully's (rho 0.4, kappa 0.05, alpha 0.9, noise 1e-3).  A Gaussian process of twenty
points over a few thousand elites is a few lines of linear algebra (a Cholesky factor, ``scipy.linalg``);
no GP library is pinned with the project (docs/repertoire.md says what was measured of QDax).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve


@dataclass(frozen=True)
class ITEConfig:
    """Settings of one adaptation (Cully et al.'s defaults)."""

    trials: int = 20
    alpha: float = 0.9
    kappa: float = 0.05
    rho: float = 0.4
    noise: float = 1e-3

    def __post_init__(self) -> None:
        if self.trials < 1:
            raise ValueError(f"trials must be >= 1, got {self.trials}")
        if not 0 <= self.alpha <= 1:
            raise ValueError(f"alpha must be in [0, 1], got {self.alpha}")
        for k in ("rho", "noise"):
            v = getattr(self, k)
            if not (v > 0 and math.isfinite(v)):
                raise ValueError(f"{k} must be > 0, got {v}")
        if not (self.kappa >= 0 and math.isfinite(self.kappa)):
            raise ValueError(f"kappa must be >= 0, got {self.kappa}")


def matern52(a, b, rho: float, variance: float = 1.0) -> np.ndarray:
    """Matérn 5/2 kernel matrix [len(a), len(b)] between points a [n, D] and b [m, D]."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    d = np.sqrt(np.maximum(((a[:, None, :] - b[None, :, :]) ** 2).sum(-1), 0.0)) / rho
    return variance * (1.0 + math.sqrt(5.0) * d + 5.0 / 3.0 * d * d) * np.exp(-math.sqrt(5.0) * d)


def posterior(x, prior, xs, ys, prior_s, rho: float, variance: float, noise: float):
    """GP posterior mean and variance [n] at points x [n, D] with prior mean ``prior`` [n] there, given
    observations ``ys`` [t] at ``xs`` [t, D] whose prior means are ``prior_s`` [t] (module docstring)."""
    prior = np.asarray(prior, np.float64)
    if len(ys) == 0:
        return prior.copy(), np.full(prior.shape, variance)
    K = matern52(xs, xs, rho, variance) + noise * variance * np.eye(len(ys))
    c = cho_factor(K, lower=True)
    k = matern52(x, xs, rho, variance)                         # [n, t]
    mu = prior + k @ cho_solve(c, np.asarray(ys, np.float64) - np.asarray(prior_s, np.float64))
    var = variance - np.einsum("nt,tn->n", k, cho_solve(c, k.T))
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
    for _ in range(cfg.trials):
        mu, var = posterior(desc, prior, desc[tried], ys, prior[tried], cfg.rho, s2, cfg.noise)
        if stop and ys and max(ys) >= cfg.alpha * float(np.max(mu)):
            reason = f"best trial >= {cfg.alpha:g} x best prediction"
            break
        ucb = mu + cfg.kappa * np.sqrt(var)
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
        mu, _ = posterior(desc, prior, desc[tried], ys, prior[tried], cfg.rho, s2, cfg.noise)
        if stop and ys and max(ys) >= cfg.alpha * float(np.max(mu)):
            reason = f"best trial >= {cfg.alpha:g} x best prediction"
    b = int(np.argmax(ys))
    return {"trials": out, "best_index": out[b]["index"], "best_fitness": ys[b], "stop": reason}
