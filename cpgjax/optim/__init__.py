"""Optimisation: the Problem, the optimisers' contract, the thesis's GA, the baselines, and the methods beyond it.

* :mod:`~cpgjax.optim.problem` — genomes in, scores out by name; :mod:`~cpgjax.optim.factory` makes one
  from a `.wl` model (or :mod:`~cpgjax.optim.analytic` test problems);
* :mod:`~cpgjax.optim.algorithm` — the ``Algorithm`` contract (``init / ask / tell`` over a typed state)
  and the one generation step;
* :mod:`~cpgjax.optim.ga` — the GA of Ch. 4.3 / 6.2 (eq. 6.1, pocketing, cross-over);
* :mod:`~cpgjax.optim.baselines` — random search and adaptive Monte Carlo (Fig. 6.10-6.11);
* :mod:`~cpgjax.optim.es` — evosax's evolution strategies; :mod:`~cpgjax.optim.mapelites` — MAP-Elites;
  :mod:`~cpgjax.optim.ite` — Intelligent Trial and Error.
"""
