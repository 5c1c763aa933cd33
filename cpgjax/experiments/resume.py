"""Resume checks: a run file is continued (``--resume``) only with what computed it.

:func:`check_resume` refuses other settings of the algorithm, genome or population sizes, and (:func:`check_problem`,
also what a sweep checks before it adds runs beside others) another episode length, terrain, evaluation, pipeline,
time step or model file; :func:`check_machine` another machine or versions (:mod:`cpgjax.io.machine`) unless
allowed, and then records the switch; :func:`check_stored_state` a stored state of another layout.  Each refusal is
a :class:`ResultsError` that names the first difference and what to do.  The drivers that resume:
:func:`cpgjax.experiments.evolve.open_run`, :mod:`cpgjax.experiments.repertoire`.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from cpgjax.errors import ResultsError
from cpgjax.io.machine import machine, machine_differences, run_machines
from cpgjax.io.results import RunWriter, read_attrs
from cpgjax.optim.algorithm import Algorithm
from cpgjax.optim.problem import Problem

# Problem settings that do not change a fitness (a moved model file, how the options were spelled).
_META_IGNORED = ("model_path", "cli_problem_args")
# meta key -> (option, what it is, unit); checked in this order, every other key after them
_META_OPTIONS = {"evaluation": ("--evaluation", "evaluation", ""), "pipeline": ("--pipeline", "physics pipeline", ""),
                 "time": ("--time", "episode length", " s"), "terrain": ("--terrain", "terrain", ""),
                 "delta": ("--delta", "delta of the fitness", ""), "replicas": ("--replicas", "replicas", ""),
                 "jitter": (None, "replicas' jitter", ""), "dt": ("--dt", "time step", " s"),
                 "controller": ("--controller", "controller", ""), "start": ("--start", "starting controller", ""),
                 "perturbations": ("--perturb", "perturbation ranges", "")}
_GIVEN_AS = {"perturbations": "perturb"}     # meta key -> its key in cli_problem_args, where they differ
_FIX = "(drop the option, or start anew with --overwrite)"


def _fmt(v: Any, unit: str = "") -> str:
    if isinstance(v, bool):
        return "on" if v else "off"
    if isinstance(v, float):
        return f"{v:g}{unit}"
    return f"{v}{unit}" if not isinstance(v, str) or v else "''"


def _show(k: str, v: Any, unit: str = "", other: Any = None) -> str:
    """A stored or new setting ``k`` as the command line spells it (``other``: the value it is compared with)."""
    if k == "controller":
        return v or "cpg"
    if k == "start":
        return json.loads(v).get("path", "?") if isinstance(v, str) else "none (the thesis's sinusoids)"
    if k == "perturbations" and isinstance(v, dict) and isinstance(other, dict):   # the keys that differ
        return ",".join(f"{n}={_fmt(v.get(n, 'unset'))}" for n in sorted(set(v) | set(other))
                        if v.get(n) != other.get(n))
    return _fmt(v, unit)


def check_resume(path: str, algo: Algorithm, problem: Problem) -> None:
    """Refuse to continue a run whose stored settings differ from these in anything that changes a fitness.

    Checked: the kind, every setting of the algorithm but ``algo.resumable_changes``, the genome and
    population sizes, and every entry of the problem's meta (episode length, terrain, delta,
    replicas and their jitter, time step, the model file's text, ...).
    """
    a = read_attrs(path)
    if a.get("kind") != algo.kind:
        kind = a.get("kind")
        what = (f"--method {algo.kind} differs from the run's {kind}" if "ga" not in (kind, algo.kind) else
                f"it holds a {'GA' if kind == 'ga' else repr(kind)} run, not a "
                f"{'GA' if algo.kind == 'ga' else repr(algo.kind)} one")
        raise ResultsError(f"{path}: cannot resume: {what} (choose another --out, or start anew with --overwrite)")
    stored = json.loads(a["config"])
    for k, v in algo.config.items():
        if k not in algo.resumable_changes and stored.get(k) != v:
            raise ResultsError(f"{path}: cannot resume: --{k.replace('_', '-')} {_fmt(v)} differs from the "
                               f"run's {_fmt(stored.get(k, 'unset'))} {_FIX}")
    check_problem(path, problem, a)     # first: a setting that differs (--controller, the model) explains the sizes
    if int(a["n_genes"]) != problem.n_genes or int(a["population"]) != algo.population:
        raise ResultsError(f"{path}: cannot resume: genome or population size differs from the stored run "
                           f"({problem.n_genes} genes x {algo.population} vs the run's {int(a['n_genes'])} x "
                           f"{int(a['population'])}) {_FIX}")


def check_problem(path: str, problem: Problem, attrs: dict | None = None, verb: str = "resume") -> None:
    """Refuse ``problem`` where the run in ``path`` was scored with other settings (episode length, terrain,
    delta, evaluation and its perturbations, physics pipeline, time step, the model file's text, ...):
    :class:`ResultsError` naming the first difference.  ``verb``: what is refused ("resume"; a sweep adding runs
    beside it: "add runs")."""
    a = attrs if attrs is not None else read_attrs(path)
    fix = _FIX if verb == "resume" else "(use the sweep's settings, or another --out)"
    old = json.loads(a.get("meta") or "{}")
    new = json.loads(json.dumps(dict(problem.meta), default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)))
    given = json.loads(new.get("cli_problem_args") or "{}")
    if "pipeline" in new and "pipeline" not in old:   # a run made before the pipeline was recorded: the thesis's
        old["pipeline"] = "springs"
    differ = [k for k in (set(old) | set(new)) - set(_META_IGNORED) if old.get(k) != new.get(k)]
    # first what an option given now changes, then the model file, then whatever else differs
    for k in [k for k in _META_OPTIONS
              if k in differ and _META_OPTIONS[k][0] and given.get(_GIVEN_AS.get(k, k)) is not None]:
        option, _, unit = _META_OPTIONS[k]
        raise ResultsError(f"{path}: cannot {verb}: {option} {_show(k, new.get(k), '', old.get(k))} differs from "
                           f"the run's {_show(k, old.get(k), unit, new.get(k))} {fix}")
    if "model_text" in differ and old.get("model_text") and new.get("model_text"):
        raise ResultsError(f"{path}: cannot {verb}: the model file {new.get('model_path', '')} changed since the "
                           "run started " + ("(restore it, or start anew with --overwrite)" if verb == "resume"
                                             else fix))
    for k in [k for k in _META_OPTIONS if k in differ] + sorted(set(differ) - set(_META_OPTIONS) - {"model_text"}):
        option, what, unit = _META_OPTIONS.get(k, (None, k, ""))
        why = fix if option or verb != "resume" else "(start anew with --overwrite)"    # no option to drop
        raise ResultsError(f"{path}: cannot {verb}: the {what} {_show(k, new.get(k), unit, old.get(k))} differs "
                           f"from the run's {_show(k, old.get(k), unit, new.get(k))} {why}")


def check_machine(path: str, completed: int, allow: bool) -> None:
    """Refuse to continue on another machine or versions than those that computed the run's last generations
    (unless ``allow``: then the file's ``machines`` attribute records the switch)."""
    machines = run_machines(read_attrs(path))
    diff = machine_differences(machines[-1])
    if not diff:
        return
    if not allow:
        raise ResultsError(f"{path}: cannot resume on another machine or versions ({'; '.join(diff)}): the numbers "
                           "would mix two machines' rounding in one run (docs/reproducibility.md); add "
                           "--allow-other-machine to go on anyway, or start anew with --overwrite")
    with RunWriter(path) as w:
        w.set_attr("machines", json.dumps(machines + [{"from_generation": completed, **machine()}]))


def check_stored_state(path: str, stored: dict[str, np.ndarray], spec: dict[str, Any]) -> None:
    """Refuse a stored state that is not what this algorithm stores (another layout, or another evosax's)."""
    for k, s in spec.items():
        if k not in stored:
            raise ResultsError(f"{path}: cannot resume: the run stores no state {k!r} (it stores "
                               f"{', '.join(sorted(stored)) or 'none'}); start anew with --overwrite")
        if tuple(np.shape(stored[k])) != tuple(s.shape):
            raise ResultsError(f"{path}: cannot resume: its state {k!r} has shape {tuple(np.shape(stored[k]))}, "
                               f"this version stores {tuple(s.shape)}; start anew with --overwrite")
