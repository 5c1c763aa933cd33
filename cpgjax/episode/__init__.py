"""An episode: a robot driven by its CPGs (Ch. 2.2.1) for T seconds, scored online (eq. 4.5-4.6).

:func:`~cpgjax.episode.rollout.rollout` is the pure ``lax.scan`` over time on one device;
:mod:`cpgjax.episode.batch` spreads a batch across the host devices and caches compiled programs.
"""

from cpgjax.episode.batch import LANES, evaluate, simulate
from cpgjax.episode.cpg import sinusoid_genome, targets
from cpgjax.episode.fitness import DEFAULT_DELTA, instantaneous, stability
from cpgjax.episode.rollout import rollout, schedule

__all__ = ["DEFAULT_DELTA", "LANES", "evaluate", "instantaneous", "rollout", "schedule", "simulate",
           "sinusoid_genome", "stability", "targets"]
