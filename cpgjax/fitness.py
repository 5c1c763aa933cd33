"""The thesis's fitness (eq. 4.5-4.6) and the bridge from a `.wl` model to a GA Problem.

Instantaneous fitness ``f = v_y S(theta)`` with the vestibular stability
``S = delta cos^2(theta) / ((delta - 1) cos^2(theta) + 1)`` (eq. 4.5, eq. 6.2), theta the
angle between the body normal and the vertical.  The episode fitness is its time
average (eq. 4.6), never above the mean forward speed.  A body turned over (normal
pointing down, cos(theta) < 0) has S = 0: it scores as fallen, not as upright, which
the symmetric cos^2 alone would not do.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

DEFAULT_DELTA = 8.0


def stability(cos_theta, delta=DEFAULT_DELTA):
    """Vestibular stability S(theta) in [0, 1] from cos(theta) (eq. 6.2); 0 when upside down."""
    c2 = jnp.square(jnp.maximum(cos_theta, 0.0))
    return delta * c2 / ((delta - 1.0) * c2 + 1.0)


def instantaneous(v_forward, cos_theta, delta=DEFAULT_DELTA):
    """eq. 4.5: forward speed weighted by the stability."""
    return v_forward * stability(cos_theta, delta)


def make_problem(wl_path: str, *, time: float | None = None, terrain: str | None = None,
                 delta: float = DEFAULT_DELTA, chunk: int = 256, dt: float | None = None,
                 replicas: int = 1, jitter: float = 1e-3):
    """A GA Problem for a `.wl` model: genome = CPG coefficients of every controlled joint.

    ``replicas > 1`` scores each genome as the mean over that many episodes, the first
    with the genome itself and the others with every gene moved by a fixed pseudo-random
    offset of standard deviation ``jitter`` (the same offsets for every genome and every
    generation, so the fitness stays deterministic).  The thesis used one episode
    (``replicas = 1``, the default); evolved gaits can be chaotic, and a single episode
    then rewards lucky controllers (docs/evolution.md, "A noisy fitness").
    """
    from cpgjax.cpg import sinusoid_genome
    from cpgjax.problem import Problem
    from cpgjax.sim.episode import evaluate
    from cpgjax.sim.model import load_model

    model = load_model(wl_path, dt=dt, terrain=terrain)
    n_ctrl, n_coeff = model.n_ctrl, model.n_coeff
    T = model.time_max if time is None else float(time)

    R = max(int(replicas), 1)
    offsets = np.random.default_rng(12345).normal(0.0, jitter, (R, model.n_genes)).astype(np.float32)
    offsets[0] = 0.0
    keys = ("fitness", "diverged", "distance", "speed", "tilt", "fallen")

    def evaluate_genomes(genomes):
        g = jnp.asarray(genomes, jnp.float32)
        n = g.shape[0]
        if R > 1:
            g = jnp.clip(g[:, None, :] + offsets[None], -0.8, 0.8).reshape(n * R, -1)
        r = evaluate(model, g.reshape(-1, n_ctrl, n_coeff), time=T, delta=delta, chunk=chunk)
        out = {k: r[k] for k in keys}
        if R > 1:
            out = {k: (v.reshape(n, R).any(1) if v.dtype == jnp.bool_ else v.reshape(n, R).mean(1))
                   for k, v in out.items()}
        return out

    desc = model.description
    meta = {
        "model_path": str(wl_path), "model_text": desc.text if desc else "", "time": T,
        "terrain": model.terrain.spec, "delta": float(delta), "dt": model.dt,
        "n_dof": n_ctrl, "harmonics": model.harmonics, "frequency": model.frequency,
        "replicas": R, "jitter": float(jitter),
    }
    base = base_genome(model) if desc else sinusoid_genome(n_ctrl, model.harmonics)
    return Problem(name=str(wl_path), n_genes=model.n_genes, base_genome=base,
                   evaluate=evaluate_genomes, meta=meta)


def base_genome(model) -> np.ndarray:
    """The GA's starting controller: one 0.5 Hz sinusoid per joint (Ch. 4.3), amplitude 0.3 rad."""
    from cpgjax.cpg import sinusoid_genome

    return sinusoid_genome(model.n_ctrl, model.harmonics, amplitude=0.3)
