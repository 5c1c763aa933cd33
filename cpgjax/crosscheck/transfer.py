"""The thesis's transfer experiment (Figs. 6.3-6.4) with MuJoCo C in the place of the robot.

The thesis evolved a gait in its simulator and ran it on the robot: 0.15 m/s simulated, 0.19 m/s
on the robot.  Here each run's best controller is replayed in our simulator and in MuJoCo C (the
exported model, :mod:`cpgjax.crosscheck.mjcf`): once as it is, and ``replays`` times with every
gene jittered by ``N(0, jitter^2)`` (the same jittered controllers in both engines).  Per run:
fitness and speed here and there, their ratio, and the falls among the jittered replays — for
runs evolved with the thesis's single episode and with the robust evaluation, side by side.

A run is replayed on the model text stored in its file (not the `.wl` on disk, which may have
changed since) and on the terrain and episode length it was evolved with (for a robust run: its
nominal terrain, without the evaluation's roughness), or on another terrain given (``terrain``: in both
engines, MuJoCo's the same field exported).

A gait *carries over* when it walks here and in MuJoCo (:data:`RULE`, :func:`failures`).
"""

from __future__ import annotations

import functools
import json
import os
import zlib
from dataclasses import dataclass

import numpy as np

from cpgjax.crosscheck.engines import mujoco_run
from cpgjax.crosscheck.mjcf import load
from cpgjax.crosscheck.ranks import spearman, spearman_interval
from cpgjax.episode.batch import simulate
from cpgjax.episode.cpg import GENE_BOX
from cpgjax.episode.policy import family_from_meta, from_genomes
from cpgjax.io.results import read_run
from cpgjax.io.sweepdir import run_files
from cpgjax.io.wl import parse_wl
from cpgjax.sim.ledges import finish_line
from cpgjax.sim.model import build_model

# What "carries over" means (the one definition, :func:`failures`): the gait walks here -- it does not fall and
# goes at least MIN_SPEED -- and in MuJoCo it scores at least MIN_RATIO of its fitness here and falls in at most
# MAX_FALLS of the jittered replays (32 by default).  Before, the first condition was missing: a gait that fell
# here (fitness 0.001) and walked in MuJoCo had ratio 181 and carried over, and so did one that barely moved.
MIN_SPEED = 0.1   # m/s, here
MIN_RATIO = 0.7   # MuJoCo's fitness over ours
MAX_FALLS = 2     # of the jittered MuJoCo replays
RULE = (f"walks here (no fall, at least {MIN_SPEED:g} m/s) and in MuJoCo at >= {MIN_RATIO:.0%} of its fitness here "
        f"with at most {MAX_FALLS} falls in the jittered replays")
# evaluation modes, as the tables name them: the run's --evaluation, the robust one split by its fall rule
FORFEITS = "robust, a fall forfeits"          # --perturb fall_zero=on
SCALES = "robust, a fall scales the score"     # --perturb fall_survival=on
MODES = ("thesis", "robust", FORFEITS, SCALES)


@dataclass
class Replay:
    """One run's best controller, replayed in both engines."""

    run: str
    evaluation: str          # one of MODES
    cell: str
    seed: int
    fitness_in_run: float    # the score the GA recorded for it
    ours: dict               # fitness, speed, fallen (the controller as it is)
    mujoco: dict
    ours_jit: dict           # mean, sd, falls over the jittered replays
    mujoco_jit: dict
    pick: dict | None = None   # how the controller was chosen, when not as the run's best (e.g. validated)
    pipeline: str = "springs"  # our side's physics pipeline (the run's, unless `replay_runs(pipeline=)`)

    @property
    def label(self) -> str:
        """How the tables name the run: ``CELL/sSEED`` for a run of a sweep folder (``CELL/sSEED.h5``), else its
        file's name without ``.h5`` (``runs/quickstart.h5``: ``quickstart``)."""
        stem = os.path.splitext(os.path.basename(self.run))[0]
        return f"{self.cell}/{stem}" if stem == f"s{self.seed}" else stem

    @property
    def group(self) -> str:
        """The summary row of its evaluation mode: the mode, with the pipeline named when not the thesis's."""
        return self.evaluation if self.pipeline == "springs" else f"{self.evaluation}, {self.pipeline} pipeline"

    @property
    def ratio(self) -> float:
        return self.mujoco["fitness"] / self.ours["fitness"] if self.ours["fitness"] > 0 else float("nan")

    @property
    def failures(self) -> list[str]:
        """Which conditions of carrying over this gait fails (:func:`failures`); empty when it carries over."""
        return failures(self.ours["fitness"], self.ours["speed"], self.ours["fallen"], self.mujoco["fitness"],
                        self.mujoco_jit["falls"], self.mujoco_jit.get("short", 0))

    @property
    def carries_over(self) -> bool:
        return not self.failures


def failures(fitness_here: float, speed_here: float, fell_here: bool, fitness_mujoco: float,
             mujoco_falls: int, mujoco_short: int = 0) -> list[str]:
    """The conditions of carrying over (:data:`RULE`) that a gait fails, each named in a few words: ``fell here``,
    ``0.03 m/s here`` (slower than :data:`MIN_SPEED`), ``MuJoCo 45 %`` (of our fitness, below :data:`MIN_RATIO`),
    ``15 MuJoCo falls`` (more than :data:`MAX_FALLS` of the jittered replays).  Empty: it carries over.

    The gait is the run's controller replayed once as it is (here and in MuJoCo); the falls are those of its
    jittered MuJoCo replays.  A gait that does not score here (fitness <= 0) has no ratio: ``MuJoCo -``.
    """
    out = []
    if fell_here:
        out.append("fell here")
    if not speed_here >= MIN_SPEED:
        out.append(f"{speed_here:.2f} m/s here")
    ratio = fitness_mujoco / fitness_here if fitness_here > 0 else float("nan")
    if not ratio >= MIN_RATIO:
        out.append(f"MuJoCo {ratio:.0%}" if np.isfinite(ratio) else "MuJoCo -")
    if mujoco_falls > MAX_FALLS:
        out.append(f"{int(mujoco_falls)} MuJoCo falls")
    if mujoco_short > MAX_FALLS:      # stairs, bars, gaps: up, but not past the last face
        out.append(f"{int(mujoco_short)} MuJoCo short")
    return out


def verdict(failed: list[str]) -> str:
    """The table's "carries over" cell: ``yes``, or ``no:`` and the conditions that failed."""
    return "yes" if not failed else "no: " + ", ".join(failed)


def sentence(r: Replay, replays: int) -> str:
    """One run's outcome in words, for a reader who did not ask for a table (``make run``'s last lines): how fast its
    gait walks here and in MuJoCo C, whether it stays up in each (once as it is, and in ``replays`` jittered
    replays), and whether it carries over (:data:`RULE`)."""
    def up(fell: bool, falls: int) -> str:
        return ("falls" if fell else "stays up") + f" as it is, {int(falls)} of {replays} jittered replays fall"
    head = (f"{r.label}: {r.ours['speed']:.3f} m/s here, {up(r.ours['fallen'], r.ours_jit['falls'])}; "
            f"{r.mujoco['speed']:.3f} m/s in MuJoCo C, {up(r.mujoco['fallen'], r.mujoco_jit['falls'])}")
    if r.carries_over:
        return head + ": it carries over"
    return head + ": it does not carry over (" + ", ".join(r.failures) + ")"




def evolved_terrain(meta) -> str | None:
    """The terrain a run was evolved on (its ``--terrain``; None: the model file's), from its meta attribute."""
    return json.loads(meta.get("cli_problem_args", "{}") or "{}").get("terrain")


def run_setting(run) -> tuple[str, float | None, str | None]:
    """(evaluation mode as the tables name it, episode length, nominal terrain) of a run: what it was evolved on."""
    cli = json.loads(run.meta.get("cli_problem_args", "{}") or "{}")
    evaluation = str(run.meta.get("evaluation", "thesis"))
    falls = run.meta.get("perturbations") or {}
    if evaluation == "robust" and falls.get("fall_zero"):          # modes of their own in the tables
        evaluation = FORFEITS
    elif evaluation == "robust" and falls.get("fall_survival"):
        evaluation = SCALES
    if evaluation != "thesis" and falls.get("bristle"):              # a foot stiffened up to 10^D: its own row
        evaluation += f", bristle up to 10^{float(falls['bristle']):g}"
    if run.meta.get("controller"):                                   # a closed-loop controller family: its own row
        evaluation += f", {run.meta['controller']}"
    return evaluation, cli.get("time") or run.meta.get("time"), evolved_terrain(run.meta)


def _stats(res: dict, finish: float | None = None) -> dict:
    """Mean, sd, falls and mean speed of jittered replays; with a ``finish`` line (stairs, bars, gaps:
    ``sim.ledges.finish_line``), ``short``: how many stayed up and did not reach it."""
    f = np.asarray(res["fitness"], float)
    fallen = np.asarray(res["fallen"])
    out = {"mean": float(f.mean()), "sd": float(f.std()), "falls": int(fallen.sum()),
           "speed": float(np.asarray(res["speed"], float).mean())}
    if finish is not None:
        out["short"] = int(np.sum(~fallen & (np.asarray(res["distance"], float) < finish)))
    return out


def variant(model, dt: float | None = None, joint_spring=None):
    """``model`` with our simulator's step and pivot springs (alpha, beta; eq. 3.6) replaced where given.

    MuJoCo's exported model depends on neither: this changes only our side of a comparison.
    """
    changes = {}
    if joint_spring is not None and model.pipeline != "springs":
        raise ValueError(f"--joint-spring sets the pivot springs of the springs pipeline (eq. 3.6); this model runs "
                         f"on the {model.pipeline} pipeline, whose joints have none")
    if dt is not None:
        changes["dt"] = float(dt)
    if joint_spring is not None:
        changes["joint_spring"] = tuple(float(v) for v in joint_spring)
    return model.replace(**changes) if changes else model


@functools.lru_cache(maxsize=8)
def cached_model(text: str, path: str, terrain, dt=None, joint_spring=None, pipeline: str = "springs"):
    """One Model object per model text: the simulator's compiled programs are cached per Model object, so the
    runs of a sweep (one model) share one compilation instead of compiling one each."""
    return variant(build_model(parse_wl(text, path), terrain=terrain, pipeline=pipeline), dt, joint_spring)


def jittered(genome, replays: int = 32, jitter: float = 1e-3, seed: int = 0) -> np.ndarray:
    """[replays + 1, G] float32: the genome as it is, then ``replays`` copies with every gene moved by N(0, jitter^2)
    (clipped to the search box, :data:`cpgjax.episode.cpg.GENE_BOX`); the draw depends on the genome and ``seed``
    only, so every replay of a controller (here, in MuJoCo, in any script) sees the same jitter."""
    g = np.asarray(genome, np.float32)
    rng = np.random.default_rng([seed, zlib.crc32(g.tobytes())])
    moved = np.clip(g[None] + rng.normal(0, jitter, (replays,) + g.shape), -GENE_BOX, GENE_BOX)
    G = np.concatenate([g[None], moved])
    return G.astype(np.float32)


def replay_runs(paths, *, replays: int = 32, jitter: float = 1e-3, seed: int = 0, dt: float | None = None,
                joint_spring=None, pipeline: str | None = None, terrain: str | None = None, pick=None,
                progress=None, mujoco_dt: float | None = None) -> list[Replay]:
    """Replay the best controller of every run in ``paths`` here and in MuJoCo C (see the module docstring).

    ``dt``, ``joint_spring``: replay here with another step or pivot springs (:func:`variant`).  ``pipeline``:
    our side's physics pipeline (None: each run's, as it recorded; MuJoCo's model does not depend on it).
    ``terrain``: replay every run on this terrain (``--terrain`` syntax), here and in MuJoCo (the same field
    exported), instead of the one it was evolved on.
    ``pick(run) -> (fitness recorded for it, genome, dict saying how it was chosen)`` chooses another controller
    of each run than its best (``cpgjax transfer --pick validated``: :mod:`cpgjax.experiments.validate`).
    ``mujoco_dt``: MuJoCo's step (None: the export's, ``mjcf.MJ_TIMESTEP``, 2 ms).  At 2 ms MuJoCo's verdict on a
    marginal gait is not converged in the step (docs/results/closed-loop.md measures it at 0.25-2 ms).
    """
    joint_spring = tuple(joint_spring) if joint_spring is not None else None
    out = []
    for path in run_files(paths):
        run = read_run(path)
        if run.completed == 0:
            raise ValueError(f"{path}: no generations in the file")
        if pick is None:
            _, _, fit, genome = run.best()
            how = None
        else:
            fit, genome, how = pick(run)
        evaluation, time, evolved_on = run_setting(run)
        text = str(run.meta.get("model_text", ""))
        if not text:
            raise ValueError(f"{path}: the run holds no model (an analytic problem?): nothing to replay")
        model = cached_model(text, str(run.meta.get("model_path", path)), terrain or evolved_on, dt, joint_spring,
                       pipeline or run.pipeline)
        T = float(time or model.episode.time_max)
        # the controller and its jittered copies: a CPG's, or a closed loop
        C = from_genomes(family_from_meta(run.meta), model, jittered(genome, replays, jitter, seed))
        ours = simulate(model, C, time=T)
        mjm = load(model) if mujoco_dt is None else load(model, timestep=mujoco_dt)
        mj, _, _ = mujoco_run(model, C, time=T, mj=mjm)
        first = lambda r, i: {k: float(np.asarray(r[k])[i]) for k in ("fitness", "speed", "distance")} | {  # noqa: E731
            "fallen": bool(np.asarray(r["fallen"])[i])}
        rest = lambda r: {k: np.asarray(r[k])[1:] for k in ("fitness", "speed", "fallen", "distance")}  # noqa: E731
        finish = finish_line(model.terrain.ledges)
        out.append(Replay(run=path, evaluation=evaluation, cell=os.path.basename(os.path.dirname(path)),
                          seed=int(run.config.get("seed", 0)), fitness_in_run=float(fit),
                          ours=first(ours, 0), mujoco=first(mj, 0), ours_jit=_stats(rest(ours), finish),
                          mujoco_jit=_stats(rest(mj), finish), pick=how, pipeline=model.pipeline))
        if progress is not None:
            progress(out[-1])
    return out


GROUPS = ("evaluation", "cell")


def _groups(replays: list[Replay], by: str) -> list[str]:
    """The summary's rows: evaluation modes in :data:`MODES` order, or the sweep's cells as they come."""
    if by not in GROUPS:
        raise ValueError(f"by must be one of {GROUPS}, not {by!r}")
    keys = list(dict.fromkeys(_key(r, by) for r in replays))
    if by == "evaluation":
        keys.sort(key=_mode_order)
    return keys


def _mode_order(group: str) -> tuple[int, int, str]:
    """Evaluation modes in :data:`MODES` order, each mode's runs of the thesis's pipeline first."""
    mode = group.rsplit(", ", 1)[0] if group.endswith(" pipeline") else group
    return (MODES.index(mode) if mode in MODES else 9, group != mode, group)


def _key(r: Replay, by: str) -> str:
    return r.group if by == "evaluation" else getattr(r, by)


def summary(replays: list[Replay], by: str = "evaluation") -> dict:
    """Per evaluation mode (``by="cell"``: per setting of a sweep): runs, median and mean ratio, falls, how many
    carry over; Spearman over all runs."""
    out: dict = {"runs": len(replays)}
    for key in _groups(replays, by):
        rs = [r for r in replays if _key(r, by) == key]
        ratios = np.array([r.ratio for r in rs], float)
        out[key] = {
            "runs": len(rs),
            "ours_fitness": float(np.mean([r.ours["fitness"] for r in rs])),
            "mujoco_fitness": float(np.mean([r.mujoco["fitness"] for r in rs])),
            "ratio_median": float(np.nanmedian(ratios)) if np.isfinite(ratios).any() else float("nan"),
            "ratio_mean": float(np.nanmean(ratios)) if np.isfinite(ratios).any() else float("nan"),
            "mujoco_falls_mean": float(np.mean([r.mujoco_jit["falls"] for r in rs])),
            "ours_falls_mean": float(np.mean([r.ours_jit["falls"] for r in rs])),
            "carry_over": int(sum(r.carries_over for r in rs)),
        }
    if len(replays) > 2:
        ours, theirs = [r.ours["fitness"] for r in replays], [r.mujoco["fitness"] for r in replays]
        out["spearman_fitness"] = spearman(ours, theirs)
        out["spearman_fitness_interval"] = spearman_interval(ours, theirs)
    return out


def _falls(jit: dict) -> str:
    return f"{jit['falls']}" + (f", {jit['short']} short" if "short" in jit else "")


def table(replays: list[Replay], replay_count: int, here: str | None = None, by: str = "evaluation") -> str:
    """The markdown table: one row per run, then one per evaluation mode, or per cell with ``by="cell"`` (``here``:
    a note on our side's model)."""
    n = replay_count
    lines = [f"Here: {here}.", ""] if here else []
    lines += [f"| run | evaluation | fitness here | speed here [m/s] | fitness MuJoCo | speed MuJoCo [m/s] | ratio | "
              f"here, {n} jittered: mean ± sd (falls) | MuJoCo, {n} jittered: mean ± sd (falls) | carries over |",
              "|---|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    for r in replays:
        fell = lambda d: " (fell)" if d["fallen"] else ""  # noqa: E731
        lines.append(
            f"| {r.label} | {r.evaluation} ({r.pipeline}) | {r.ours['fitness']:.3f}{fell(r.ours)} | "
            f"{r.ours['speed']:.3f} | "
            f"{r.mujoco['fitness']:.3f}{fell(r.mujoco)} | {r.mujoco['speed']:.3f} | {r.ratio:.2f} | "
            f"{r.ours_jit['mean']:.3f} ± {r.ours_jit['sd']:.3f} ({_falls(r.ours_jit)}) | "
            f"{r.mujoco_jit['mean']:.3f} ± {r.mujoco_jit['sd']:.3f} ({_falls(r.mujoco_jit)}) | "
            f"{verdict(r.failures)} |")
    s = summary(replays, by)
    lines += ["", f"| {'setting' if by == 'cell' else 'evaluation'} | runs | mean fitness here | mean fitness MuJoCo | "
              f"ratio (median) | MuJoCo falls of {n} (mean) | falls here of {n} (mean) | runs that carry over |",
              "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for key in _groups(replays, by):
        m = s[key]
        lines.append(f"| {key} | {m['runs']} | {m['ours_fitness']:.3f} | {m['mujoco_fitness']:.3f} | "
                     f"{m['ratio_median']:.2f} | {m['mujoco_falls_mean']:.1f} | "
                     f"{m['ours_falls_mean']:.1f} | {m['carry_over']} of {m['runs']} |")
    if "spearman_fitness" in s:
        lines += ["", f"Spearman rank correlation of fitness, here vs MuJoCo, over these runs' bests: "
                      f"{s['spearman_fitness']:+.2f} (95 % bootstrap interval "
                      f"[{s['spearman_fitness_interval'][0]:+.2f}, {s['spearman_fitness_interval'][1]:+.2f}])"]
    lines += ["", f"Carries over: walks here (no fall, at least {MIN_SPEED:g} m/s) and in MuJoCo at ≥ {MIN_RATIO:.0%} "
                  f"of its fitness here with at most {MAX_FALLS} falls in the {n} jittered MuJoCo replays."]
    return "\n".join(lines)


def plot(replays: list[Replay], out: str) -> None:
    """Fitness here vs in MuJoCo, one point per run, coloured by evaluation mode (cf. thesis Fig. 6.3-6.4)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 5), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    hi = max([0.05] + [max(r.ours["fitness"], r.mujoco["fitness"]) for r in replays]) * 1.1
    ax.plot([0, hi], [0, hi], "k:", lw=1, label="same in both")
    ax.plot([0, hi], [0, MIN_RATIO * hi], color="0.6", lw=1, label=f"{MIN_RATIO:.0%} of ours")
    colors = dict(zip(MODES, ("tab:red", "tab:blue", "tab:green", "tab:purple"), strict=True))
    others = iter(("tab:orange", "tab:brown", "tab:cyan", "tab:olive", "tab:pink"))
    colors |= {m: next(others, "0.3") for m in sorted({r.group for r in replays} - set(MODES))}
    for mode in sorted({r.group for r in replays}, key=_mode_order):
        rs = [r for r in replays if r.group == mode]
        fell = [r.mujoco_jit["falls"] > MAX_FALLS for r in rs]
        ax.errorbar([r.ours["fitness"] for r in rs], [r.mujoco_jit["mean"] for r in rs],
                    yerr=[r.mujoco_jit["sd"] for r in rs], fmt="none", ecolor=colors.get(mode, "0.3"), alpha=0.6)
        for hollow in (False, True):
            pts = [r for r, f in zip(rs, fell, strict=True) if f == hollow]
            if pts:
                ax.plot([r.ours["fitness"] for r in pts], [r.mujoco_jit["mean"] for r in pts], "o",
                        color=colors.get(mode, "0.3"), mfc="none" if hollow else colors.get(mode, "0.3"),
                        label=f"{mode}: {'falls' if hollow else 'stays up'} in MuJoCo")
    ax.text(0.98, 0.02, f"best of each run; MuJoCo: mean ± sd of jittered replays;\nhollow: > {MAX_FALLS} "
            "of them fall", transform=ax.transAxes, ha="right", va="bottom", fontsize=7)
    ax.set_xlabel("fitness in the penalty simulator (eq. 4.6)")
    ax.set_ylabel("fitness in MuJoCo C")
    ax.set_title("Do evolved gaits carry over? (MuJoCo as the robot)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))   # beside the axes: no point hidden
    fig.savefig(out, dpi=110)


def _number(cell: str) -> tuple[float, bool]:
    """(value, fell) of a table cell such as ``0.284 (fell)`` or ``−0.009``."""
    text = cell.strip().replace("−", "-")
    return float(text.split()[0]), "(fell)" in text


def read_table(text: str) -> list[dict]:
    """The per-run rows of a transfer table (``transfer.md``, as :func:`table` writes it): run, evaluation, fitness
    and speed here and in MuJoCo, whether it fell in each, the falls of the jittered MuJoCo replays (``replays``:
    how many), and the table's own verdict (``carried``).  Other lines are skipped."""
    rows, replays = [], None
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("| run | evaluation | fitness here |"):
            head = next((c for c in cells if c.startswith("MuJoCo, ") and "jittered" in c), "")
            replays = int(head.split()[1]) if head else None
            continue
        if replays is None or len(cells) != 10 or cells[0] in ("run", "---"):
            continue
        try:
            (fh, fell_here), (sh, _), (fm, fell_mj), (sm, _) = (_number(c) for c in cells[2:6])
            falls = int(cells[8].rsplit("(", 1)[1].rstrip(")"))
        except (ValueError, IndexError):
            continue
        rows.append({"run": cells[0], "evaluation": cells[1], "fitness_here": fh, "speed_here": sh,
                     "fell_here": fell_here, "fitness_mujoco": fm, "speed_mujoco": sm, "fell_mujoco": fell_mj,
                     "mujoco_falls": falls, "replays": replays, "carried": cells[9].startswith("yes")})
    return rows


def restate(rows: list[dict]) -> list[dict]:
    """Each row of :func:`read_table` judged again by today's rule (:func:`failures`): ``failures`` added."""
    return [r | {"failures": failures(r["fitness_here"], r["speed_here"], r["fell_here"], r["fitness_mujoco"],
                                      r["mujoco_falls"])} for r in rows]


def restate_text(path: str, rows: list[dict]) -> str:
    """A table's runs judged by today's rule beside the verdict the table recorded: one line per run whose verdict
    changed or that fails, then the counts."""
    rows = restate(rows)
    lines = [f"{path}: {len(rows)} runs"]
    for r in rows:
        now = verdict(r["failures"])
        if r["carried"] != (not r["failures"]):
            lines.append(f"  {r['run']} ({r['evaluation']}): was {'yes' if r['carried'] else 'no'}, now {now}")
    old = sum(r["carried"] for r in rows)
    new = sum(not r["failures"] for r in rows)
    lines.append(f"  carry over: {new} of {len(rows)} ({RULE}); the table said {old} of {len(rows)}")
    return "\n".join(lines)
