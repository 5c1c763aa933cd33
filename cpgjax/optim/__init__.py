"""Optimisation: the Problem, the thesis's GA, the baselines, and the adapter every algorithm goes through.

* :mod:`~cpgjax.optim.problem` — genomes in, fitness out; :mod:`~cpgjax.optim.factory` makes one
  from a `.wl` model (or :mod:`~cpgjax.optim.analytic` test problems);
* :mod:`~cpgjax.optim.ga` — the GA of Ch. 4.3 / 6.2 (eq. 6.1, pocketing, cross-over);
* :mod:`~cpgjax.optim.baselines` — random search and adaptive Monte Carlo (Fig. 6.10-6.11);
* :mod:`~cpgjax.optim.algorithm` — the ``init / propose / update`` adapter and the one generation step.
"""
