"""Central pattern generators: one Fourier series per controlled joint (Ch. 2.2.1).

``q*(t) = c0 + sum_k a_k sin(2 pi k f0 t) + b_k cos(2 pi k f0 t)``, k = 1..K, f0 = 0.5 Hz.
A controller's coefficients are ``[n_ctrl, 2K+1]`` in the `.ctl` order
(c0, a1, b1, a2, b2, ...); the GA's genome is that array flattened row-major, every gene searched in
``[-GENE_BOX, GENE_BOX]`` (:data:`GENE_BOX`).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

GENE_BOX = 0.8
"""Half-width of the genome search box: every gene is searched in ``[-GENE_BOX, GENE_BOX]`` (rad for a CPG
coefficient), the hypercube of side 1.6 of the thesis's searches (Ch. 6.2.5).  The GA clips its children to it,
random search draws in it, :class:`cpgjax.optim.problem.Problem` takes it as its default ``lower`` / ``upper``;
a closed-loop controller's policy genes share it (:mod:`cpgjax.episode.policy`)."""


def basis(t, harmonics: int, f0: float):
    """[2K+1] basis values and their time derivatives at time t."""
    vals, ders = [jnp.ones_like(t)], [jnp.zeros_like(t)]
    for k in range(1, harmonics + 1):
        w = 2 * np.pi * k * f0
        s, c = jnp.sin(w * t), jnp.cos(w * t)
        vals += [s, c]
        ders += [w * c, -w * s]
    return jnp.stack(vals), jnp.stack(ders)


def targets(coeffs, t, harmonics: int, f0: float):
    """Target angles and rates [n_ctrl, B] for coefficients [n_ctrl, 2K+1, B] at time t."""
    b, db = basis(t, harmonics, f0)
    # explicit sums, not einsum: a dot's summation order depends on the batch shape
    return (b[None, :, None] * coeffs).sum(1), (db[None, :, None] * coeffs).sum(1)


def sinusoid_genome(n_ctrl: int, harmonics: int, amplitude: float = 0.3, phases=None) -> np.ndarray:
    """The thesis's starting controller: one 0.5 Hz sinusoid per joint (Ch. 4.3)."""
    c = np.zeros((n_ctrl, 2 * harmonics + 1))
    ph = np.zeros(n_ctrl) if phases is None else np.asarray(phases, float)
    c[:, 1] = amplitude * np.cos(ph)
    c[:, 2] = amplitude * np.sin(ph)
    return c.reshape(-1)
