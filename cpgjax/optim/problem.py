"""The optimisation problem the GA and the baselines see: genomes in, fitness out.

A :class:`Problem` hides the simulator: the real one is built from a `.wl` model by
:func:`cpgjax.optim.factory.make_problem` (the thesis fitness, eq. 4.5-4.6, averaged over an
episode).  The genome of a controller is its `.ctl` coefficients flattened row-major, per
controlled joint ``c0 a1 b1 ... aK bK`` (Ch. 2.2.1), searched in ``[-GENE_BOX, GENE_BOX]`` per gene
(:data:`cpgjax.episode.cpg.GENE_BOX`: the hypercube of side 1.6 of Ch. 6.2.5).

Cheap problems with a known optimum, for the tests, are in :mod:`cpgjax.optim.analytic`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import jax
import numpy as np

from cpgjax.episode.cpg import GENE_BOX

Evaluate = Callable[..., dict[str, jax.Array]]


@dataclass(frozen=True)
class Problem:
    """A fitness to maximise over genomes in the box ``[lower, upper]^n_genes`` (by default the genome box,
    ``[-GENE_BOX, GENE_BOX]``, :data:`cpgjax.episode.cpg.GENE_BOX`).

    ``evaluate(genomes [N, G] float32)`` returns ``{"fitness": [N] float32, "diverged": [N] bool}``
    plus optional per-individual metrics (``[N]`` arrays, e.g. ``distance``, ``speed``, ``tilt``), all of which
    reach an algorithm's ``tell`` by name (:class:`cpgjax.optim.algorithm.Algorithm`) and the run file.
    It must be pure, deterministic and traceable inside ``jit``/``lax.scan`` (no host callbacks);
    ``N`` may be any size.  Fitness may be NaN/inf for diverged episodes: the GA replaces such
    values by the population's worst finite fitness and counts them (see :mod:`cpgjax.optim.ga`).

    ``stochastic`` problems (the robust evaluation) take a second argument, ``keys [N]``: one PRNG key
    per genome, from which its perturbations are drawn; the drivers derive them from the run's seed,
    the generation and the individual's index (:func:`cpgjax.optim.algorithm.eval_keys`), so a run
    stays reproducible and resumable bit for bit.

    ``base_genome`` is the thesis's start (Ch. 4.3): one 0.5 Hz sinusoid per joint.
    ``meta`` holds strings and numbers stored as HDF5 attributes of a run (model path and text,
    simulation settings, ``n_dof`` and ``harmonics`` to turn a genome back into a `.ctl`).

    ``length``: the episode's length as data (:func:`cpgjax.episode.rollout.episode_length`), or None.  Where set,
    ``evaluate`` also takes it as the keyword ``length`` (its default: this one), and the drivers pass it as an
    argument of the compiled program (:func:`cpgjax.optim.algorithm.make_chunk_fn`): one program for every
    episode length of a model and population.

    ``held``: [n_genes] bool, the genes the search keeps at ``base_genome`` (``cpgjax evolve --free``: only the
    other genes evolve), or None: every gene evolves.  The GA honours it; the other searches refuse it.
    """

    name: str
    n_genes: int
    base_genome: np.ndarray
    evaluate: Evaluate
    lower: float = -GENE_BOX
    upper: float = GENE_BOX
    meta: dict = field(default_factory=dict)
    stochastic: bool = False
    length: Any = None
    held: Any = None
