"""The ``stability`` subcommand of ``cpgjax``: stability under perturbation (thesis Ch. 6.4, Figs. 6.13-6.21).

``cpgjax stability MODEL.wl --ctl A.ctl [B.ctl ...] [--bump 0.01,0.02,0.03] [--rough 0.01,0.02,0.03,0.04]
[--seeds N] --out DIR`` walks each controller on flat ground, over each bump and on each roughness range
(N fields), every controller x condition x field in one batch, and writes the series (``stability.npz``),
the thesis-style figures and ``summary.json`` (fall rate and mean stability per condition).

``cpgjax stability RUN.h5|SWEEP_DIR ... --out DIR`` scores the final population of each run (``--which
best``: the best of each generation) under the same perturbations and writes the fall probability per GA
setting and condition, with the spread over seeds (``population.json``, ``population.png``, ``population.md``).
"""

from __future__ import annotations

import argparse
import json
import os
import re
from typing import Any

from cpgjax.cli import options as o


def _heights(text: str) -> list[float]:
    """A comma list of metres >= 0, or ``none`` (no such perturbation)."""
    if text.strip().lower() == "none":
        return []
    return o.list_of(o.nonneg, "expected heights in metres >= 0, e.g. 0.01,0.02,0.03, or none")(text)


def register(subparsers: Any) -> None:
    from cpgjax.experiments.stability import StabilityConfig

    d = StabilityConfig()
    s = subparsers.add_parser("stability")
    s.add_argument("inputs", nargs="+", metavar="MODEL.wl | RUN.h5 | SWEEP_DIR",
                   help="a model with --ctl controllers, or run files / sweep folders (population study)")
    s.add_argument("--ctl", nargs="+", default=[], help="controllers (.ctl) to test on MODEL.wl")
    s.add_argument("--bump", type=_heights, default=list(d.bumps),
                   help="heights of a bump across the path halfway, m (default 0.01,0.02,0.03 as the thesis; none: no "
                        "bump)")
    s.add_argument("--rough", type=_heights, default=list(d.roughs),
                   help="ranges of rough ground to walk on, m: heights uniform from 0 to each (default "
                        "0.01,0.02,0.03,0.04 as the thesis; none: no rough ground)")
    s.add_argument("--stair", type=_heights, default=list(d.stairs),
                   help="rises of a flight of 3 stairs (0.3 m treads, vertical risers) halfway, m, beside the thesis's "
                        "bump (e.g. 0.02,0.04; default none)")
    s.add_argument("--bar", type=_heights, default=list(d.bars),
                   help="heights of a bar (5 cm deep, vertical faces) halfway, m (e.g. 0.01,0.03; default none)")
    s.add_argument("--seeds", type=o.count, default=d.seeds, help=f"rough fields per range (default {d.seeds})")
    s.add_argument("--bump-width", type=o.positive, default=d.bump_width,
                   help=f"bump length along the path, m (default {d.bump_width:g})")
    o.time_option(s, of=o.RUN_OR_FILE)
    s.add_argument("--delta", type=o.positive, default=d.delta,
                   help=f"delta of the vestibular stability S = delta cos^2(t) / ((delta - 1) cos^2(t) + 1), t the "
                        f"body's tilt from upright: 1 upright, 0 on its side; a robot has fallen when S drops below "
                        f"its value at 60 degrees (default {d.delta:g})")
    s.add_argument("--which", choices=("final", "best"), default="final",
                   help="population study: each run's final population, or its best of each generation (default final)")
    s.add_argument("--top", type=o.count, help="population study: only the TOP fittest of those per run")
    s.add_argument("--block", type=o.count, default=d.block, help=f"robots per compiled call (default {d.block})")
    s.add_argument("--out", default=os.path.join("runs", "stability"), help="folder for the tables and figures "
                                                                            "(default runs/stability)")
    s.add_argument("--json", action="store_true", help="print one JSON object of summary figures")
    o.pipeline_option(s, "the model file's Pipeline, else springs; for run files, the runs', as they recorded")
    s.set_defaults(func=cmd_stability)


def _config(args):
    from cpgjax.experiments.stability import StabilityConfig

    return StabilityConfig(bumps=tuple(args.bump), roughs=tuple(args.rough), seeds=args.seeds,
                           bump_width=args.bump_width, time=args.time, delta=args.delta, block=args.block,
                           stairs=tuple(args.stair), bars=tuple(args.bar))


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", os.path.splitext(os.path.basename(name))[0]) or "ctl"


def _pick_header(name: str, p: dict, pipeline: str | None):
    """The `.ctl` header of the population study's ``name`` pick ``p`` (its run's settings; the study's pipeline
    added when it is another)."""
    from cpgjax.episode.policy import family_from_meta
    from cpgjax.experiments.stability import model_of
    from cpgjax.io.ctl import run_header
    from cpgjax.io.results import read_run

    run = read_run(p["run"])
    family = family_from_meta(run.meta)
    how = "highest" if name == "stable" else "lowest"
    header = run_header(p["run"], run.meta, model_of(run)[0], family.spec if family else "cpg",
                        f"the {name} one of a population study (cpgjax stability): among the walkers, the {how} mean "
                        f"S on flat ground ({p['S_flat']:.4g}); GA fitness {p['ga_fitness']:.4g}")
    if pipeline and pipeline not in header.pipelines:
        header.pipeline += f", {pipeline}"
    return header


def cmd_stability(args: argparse.Namespace) -> int:
    o.check_output_dir(args.out)
    wl = [p for p in args.inputs if p.lower().endswith(".wl")]
    if wl:
        if len(args.inputs) != 1:
            raise ValueError("give one MODEL.wl (with --ctl), or run files and sweep folders, not both")
        if not args.ctl:
            raise ValueError("a model needs controllers: --ctl A.ctl [B.ctl ...]")
        return _controllers(args, wl[0])
    if args.ctl:
        raise ValueError("--ctl goes with a MODEL.wl; run files bring their own controllers")
    return _population(args)


def _controllers(args, model_path: str) -> int:
    from cpgjax.episode.policy import from_control, stack
    from cpgjax.experiments.stability import perturbation_experiment, save
    from cpgjax.io.ctl import read_ctl
    from cpgjax.io.wl import load_model
    from cpgjax.plots.stability import condition_panels, flat_panel

    model = load_model(model_path, pipeline=args.pipeline)
    coeffs = stack([from_control(read_ctl(c, n_dof=model.n_ctrl, harmonics=model.episode.harmonics), model)
                    for c in args.ctl], model)
    names = [_slug(c) for c in args.ctl]
    if len(set(names)) < len(names):
        names = [f"{i}-{n}" for i, n in enumerate(names)]
    res = perturbation_experiment(model, coeffs, names, _config(args), progress=not args.json)
    os.makedirs(args.out, exist_ok=True)
    written = [save(res, args.out)]
    for i, name in enumerate(names):
        for measure in ("vestibular", "projection"):
            figs = [(kind, condition_panels(res, i, measure, kind)) for kind in ("bump", "rough", "stair", "bar")]
            if all(f is None for _, f in figs):
                figs = [("flat", flat_panel(res, i, measure))]
            for kind, fig in figs:
                if fig is not None:
                    path = os.path.join(args.out, f"{name}-{measure}-{kind}.png")
                    fig.savefig(path, dpi=110)
                    written.append(path)
    summary = {"model": model_path, "pipeline": model.pipeline, "controllers": dict(zip(names, args.ctl, strict=True)),
               "episode_s": float(res.t[-1]), "samples": int(len(res.t)),
               "flat_distance": dict(zip(names, map(float, res.flat_distance), strict=True)),
               "conditions": res.summary()}
    with open(os.path.join(args.out, "summary.json"), "w") as f:
        json.dump(summary, f, indent=1)
    if args.json:
        print(json.dumps(summary))
        return 0
    groups = [g for g, _ in res.groups()]
    print(f"{model_path} ({model.pipeline} pipeline): {len(names)} controllers x {len(res.conditions)} grounds, "
          f"{res.t[-1]:g} s each "
          "(fell: body tilted past 60 degrees; S: mean S(θ), eq. 6.2; proj: mean projection stability, "
          "undef: share of samples with < 3 vertices down)")
    print(f"{'controller':<24}{'ground':<14}{'fell':>6}{'S':>8}{'proj':>8}{'undef':>7}{'dist m':>8}")
    for name, rows in summary["conditions"].items():
        for g in groups:
            r = rows[g]
            pm = "-" if r["proj_mean"] is None else f"{r['proj_mean']:.3f}"
            print(f"{name:<24}{g:<14}{100 * r['fall_rate']:>5.0f}%{r['mean_S']:>8.3f}{pm:>8}"
                  f"{100 * r['proj_undefined']:>6.0f}%{r['distance']:>8.3f}")
    print("wrote " + ", ".join(written + [os.path.join(args.out, "summary.json")]))
    return 0


def population_table(study, what: str = "fall") -> str:
    """Markdown: fall probability (``what="fall"``) or mean time to fall in s (``"time_to_fall"``), mean ± sd
    over seeds, per GA setting and condition."""
    s = study.summary()
    head = "| GA setting | runs | " + " | ".join(study.groups) + " | all perturbed |"
    lines = [head, "|" + "---|" * (len(study.groups) + 3)]
    fmt = ".2f" if what == "fall" else ".1f"
    for lab in study.labels:
        r = s[lab]
        cells = [f"{r[what][g]['mean']:{fmt}} ± {r[what][g]['sd']:{fmt}}" for g in study.groups]
        lines.append(f"| {lab} | {r['runs']} | " + " | ".join(cells) + f" | {r[what + '_perturbed']:{fmt}} |")
    return "\n".join(lines)


def _population(args) -> int:
    from cpgjax.experiments.stability import population_study
    from cpgjax.plots.stability import fall_probability

    study = population_study(args.inputs, _config(args), which=args.which, top=args.top, progress=not args.json,
                             pipeline=args.pipeline)
    os.makedirs(args.out, exist_ok=True)
    summary = {"inputs": args.inputs, "controllers_per_run": study.controllers, "which": args.which,
               "groups": study.groups, "settings": study.summary(), "config": study.config}
    ranking, summary["most_robust"] = study.ranking()      # None: a tie
    summary["ranking"] = ranking
    falls = [summary["settings"][lab]["fall_perturbed"] for lab in ranking]
    from cpgjax.io.ctl import PolicyTable, write_ctl

    summary["picks"] = {}
    for name, p in study.picks.items():     # the thesis's stable and unstable controller, for the figures
        path = os.path.join(args.out, f"{name}.ctl")
        policy = PolicyTable(**p["policy"]) if p.get("policy") else None    # a closed-loop controller's
        write_ctl(path, p["coeffs"], p["ga_fitness"], exact=True, policy=policy,
                  header=_pick_header(name, p, study.config.get("pipeline")))
        summary["picks"][name] = {"ctl": path, **{k: v for k, v in p.items() if k not in ("coeffs", "policy")}}
    with open(os.path.join(args.out, "population.json"), "w") as f:
        json.dump(summary, f, indent=1)
    fall_probability(study).savefig(os.path.join(args.out, "population.png"), dpi=110)
    fall_probability(study, "time_to_fall").savefig(os.path.join(args.out, "population-time.png"), dpi=110)
    text = (f"Fall probability of the {args.which} controllers ({study.controllers} per run) of each GA setting "
            f"({study.config.get('pipeline', 'springs')} pipeline), mean ± sd over seeds\n\n"
            + population_table(study) + "\n\nMean time to fall [s] (the episode's length for a controller that "
            "stays up), mean ± sd over seeds\n\n"
            + population_table(study, "time_to_fall") + "\n")
    with open(os.path.join(args.out, "population.md"), "w") as f:
        f.write(text)
    if args.json:
        print(json.dumps(summary))
    else:
        print(text)
        print("most robust (lowest fall probability over the perturbed grounds, then the longest time to fall): "
              + (summary["most_robust"] or f"none: a tie at fall probability {falls[0]:.2f}"))
        for name, p in summary["picks"].items():
            print(f"{name}: {p['ctl']} (from {p['run']}; GA fitness {p['ga_fitness']:.4f}, mean S on flat ground "
                  f"{p['S_flat']:.4f})")
        print(f"wrote {args.out}/population.json, population.md, population.png, population-time.png, stable.ctl, "
              "unstable.ctl")
    return 0
