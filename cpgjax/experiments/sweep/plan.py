"""The plan of a sweep: cells (settings) x seeds, their names and files, and the thesis experiment.

A *cell* is one setting (e.g. GA with gamma 0.1, pocket 4, no cross-over; or AMC with M = 5);
a *run* is a cell with one seed, written to ``OUT/<cell>/s<seed>.h5``.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from cpgjax.errors import ResultsError
from cpgjax.io.results import read_attrs
from cpgjax.optim import baselines, es, ga

MANIFEST = "sweep.json"


@dataclass(frozen=True)
class RunSpec:
    """One run of a sweep: a cell (setting), its configuration (with the seed) and its file."""

    cell: str
    kind: str                                  # "ga" | "random" | "amc" | an ES method ("cmaes", ...)
    cfg: ga.GAConfig | baselines.SearchConfig | es.ESConfig
    path: str

    @property
    def seed(self) -> int:
        return int(self.cfg.seed)


def _fmt(v: float) -> str:
    return f"{float(v):g}"


def ga_cell_name(cfg: ga.GAConfig) -> str:
    """``ga_n20_mu0.2_g0.01_p4_xoff`` (plus the non-default mutation settings)."""
    name = (f"ga_n{cfg.population}_mu{_fmt(cfg.mu_max)}_g{_fmt(cfg.gamma)}_p{cfg.pocket}"
            f"_x{'on' if cfg.crossover else 'off'}")
    d = ga.GAConfig()
    if cfg.mutation != d.mutation:
        name += f"_{cfg.mutation}"
    if cfg.sigma != d.sigma:
        name += f"_s{_fmt(cfg.sigma)}"
    if cfg.selection != d.selection:
        name += f"_{cfg.selection}"
    return name


def search_cell_name(cfg: baselines.SearchConfig | es.ESConfig) -> str:
    """``random``, ``amc_M5``, or an evolution strategy: ``cmaes_n20_s0.2``, ``openes_n20_s0.2_lr0.05``."""
    if isinstance(cfg, es.ESConfig):
        name = f"{cfg.method}_n{cfg.population}_s{_fmt(cfg.sigma)}"
        return name + (f"_lr{_fmt(cfg.lr)}" if cfg.method in es.GRADIENT else "")
    return "random" if cfg.method == "random" else f"amc_M{cfg.M}"


def ga_grid(*, gamma: Sequence[float] = (0.0,), pocket: Sequence[int] = (0,), crossover: Sequence[bool] = (False,),
            population: Sequence[int] = (20,), **common: Any) -> list[ga.GAConfig]:
    """Every combination of the listed GA settings (``common``: other GAConfig fields, seed excluded)."""
    return [ga.GAConfig(population=n, gamma=float(g), pocket=int(p), crossover=bool(x), **common)
            for n in population for p in pocket for x in crossover for g in gamma]


def baseline_cells(methods: Sequence[str], *, samples: int = 3000, batch: int = 20,
                   es_population: Sequence[int] | None = None, es_sigma: Sequence[float] | None = None,
                   es_lr: Sequence[float] | None = None,
                   **common: Any) -> list[baselines.SearchConfig | es.ESConfig]:
    """Baseline cells from names ``random``, ``amc3``, ``amc5``, ... (``amcM``: adaptive MC with M variables)
    and the evolution strategies ``cmaes``, ``sep_cmaes``, ``openes``, ``pgpe``, ``snes``
    (:mod:`cpgjax.optim.es`), each for every listed population (default ``batch``), sigma and
    learning rate (defaults: :class:`cpgjax.optim.es.ESConfig`'s; the rate only for openes / pgpe)."""
    d = es.ESConfig()
    out: list[baselines.SearchConfig | es.ESConfig] = []
    for m in methods:
        m = m.strip().lower()
        if m in es.METHODS:
            lrs = (es_lr or [d.lr]) if m in es.GRADIENT else [d.lr]
            out += [es.ESConfig(method=m, samples=samples, population=int(n), sigma=float(sg), lr=float(lr),
                                **common)
                    for n in (es_population or [batch]) for sg in (es_sigma or [d.sigma]) for lr in lrs]
        elif m == "random":
            out.append(baselines.SearchConfig(method="random", samples=samples, batch=batch, **common))
        elif m.startswith("amc") and m[3:].isdigit():
            out.append(baselines.SearchConfig(method="amc", M=int(m[3:]), samples=samples, batch=batch, **common))
        else:
            raise ValueError(f"unknown baseline {m!r}: expected random, amcM (e.g. amc5) or an evolution strategy "
                             f"({', '.join(es.METHODS)})")
    return out


def plan(out_dir: str | os.PathLike[str], cells: Sequence[ga.GAConfig | baselines.SearchConfig | es.ESConfig],
         seeds: Sequence[int], chunk: int | None = None) -> list[RunSpec]:
    """The runs of ``cells`` x ``seeds`` with their files under ``out_dir``."""
    specs, seen = [], set()
    for c in cells:
        if isinstance(c, ga.GAConfig):
            kind, name = "ga", ga_cell_name(c)
        else:
            kind, name = c.method, search_cell_name(c)
        if name in seen:
            continue
        seen.add(name)
        for s in seeds:
            cfg = dataclasses.replace(c, seed=int(s), **({} if chunk is None else {"chunk": int(chunk)}))
            specs.append(RunSpec(name, kind, cfg, os.path.join(os.fspath(out_dir), name, f"s{int(s)}.h5")))
    return specs


# --- the thesis experiment, at two scales (shared by the CLI preset and the notebook) -------------------

SCALES: dict[str, dict[str, Any]] = {
    # thesis Ch. 6.2-6.3: population 20, 150 generations (3000 evaluations), mu_max 20 %, pocket 4
    "full": {"model": "models/quadruped.wl", "time": None, "population": 20, "generations": 150,
             "mu_max": 0.2, "gammas": (0.0, 0.01, 0.1, 1.0), "pocket": 4, "seeds": 5, "samples": 3000,
             "Ms": (3, 5, 10)},
    # for the tests: the quadruped, 0.5 s episodes, 6 individuals, 3 generations, 2 seeds
    "tiny": {"model": "models/quadruped.wl", "time": 0.5, "population": 6, "generations": 3,
             "mu_max": 0.2, "gammas": (0.0, 1.0), "pocket": 2, "seeds": 2, "samples": 18,
             "Ms": (3, 5)},
}


def thesis_cells(scale: str | dict[str, Any] = "full") -> list[ga.GAConfig | baselines.SearchConfig]:
    """The cells of Fig. 6.5-6.12: GA gamma x pocket {0, P} without cross-over, gamma x pocket P with
    cross-over; random search and adaptive MC (M = 3, 5, 10) on the GA's budget."""
    s = SCALES[scale] if isinstance(scale, str) else scale
    common = {"population": (s["population"],), "generations": s["generations"], "mu_max": s["mu_max"]}
    cells: list[ga.GAConfig | baselines.SearchConfig] = []
    cells += ga_grid(gamma=s["gammas"], pocket=(0, s["pocket"]), crossover=(False,), **common)
    cells += ga_grid(gamma=s["gammas"], pocket=(s["pocket"],), crossover=(True,), **common)
    cells += baseline_cells(["random"] + [f"amc{m}" for m in s["Ms"]], samples=s["samples"],
                            batch=s["population"])
    return cells


def total_batch(specs: Sequence[RunSpec]) -> int:
    """Evaluations per sweep generation when every run of ``specs`` is in one batch."""
    return sum(s.cfg.population for s in specs)


def complete(specs: Sequence[RunSpec]) -> bool:
    """True when every run of ``specs`` has a complete file."""
    for s in specs:
        if not os.path.exists(s.path):
            return False
        try:
            a = read_attrs(s.path)
        except (OSError, ResultsError):
            return False
        if int(a["completed"]) < int(a["generations"]):
            return False
    return True
