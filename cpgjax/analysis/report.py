"""The summary of a sweep and the thesis's claims checked against it (``cpgjax report``)."""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from cpgjax.analysis.cells import ES_NAMES, load_cells
from cpgjax.io.results import machines_line, read_attrs, writing_note
from cpgjax.io.sweepdir import find_runs, same_setting

PLATEAU = 20   # generations at the end over which the GA's best-of-generation is averaged ("plateau")


def _ms(v) -> str:
    v = np.asarray(v, float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return "–"
    return f"{v.mean():.3g} ± {v.std(ddof=1) if v.size > 1 else 0.0:.2g}"


def _mean(v) -> float:
    v = np.asarray(v, float)
    v = v[np.isfinite(v)]
    return float(v.mean()) if v.size else float("nan")


def cell_stats(cell) -> dict[str, Any]:
    """Per-seed numbers of a cell (:class:`cpgjax.plots.thesis.Cell`): best found, plateau, t90, mean, oscillation."""
    bpg = cell.best_per_generation()                    # [S, G]
    bsf = cell.best_so_far()
    g = bpg.shape[1]
    k = max(1, min(PLATEAU, g // 3 or 1))
    plateau = np.nanmean(bpg[:, -k:], axis=1) if cell.kind == "ga" else bsf[:, -1]
    # generation at which a 10-generation running mean of the best first reaches 90 % of the plateau
    w = max(1, min(10, g // 5 or 1))
    run = np.stack([np.convolve(np.nan_to_num(b, nan=-1.0), np.ones(w) / w, mode="valid") for b in bpg])
    start = bpg[:, 0]
    t90 = np.array([int(np.argmax(r >= s + 0.9 * (p - s))) + w - 1 if p > s else 0
                    for r, s, p in zip(run, start, plateau, strict=True)], float)
    tail = bpg[:, -max(1, min(50, g // 3 or 1)):]
    osc = np.nanstd(tail, axis=1) / np.abs(np.nanmean(tail, axis=1))
    return {"best": np.nanmax(bsf, axis=1), "plateau": plateau, "t90": t90,
            "mean_all": np.nanmean(cell.fitness, (1, 2)), "diversity": np.nanmean(cell.diversity[:, -k:], axis=1),
            "oscillation": osc, "evaluations": int(cell.evaluations()[-1]), "seeds": len(cell.seeds)}


def _verdict(ok: bool | None, text: str) -> str:
    return {True: "**yes**", False: "**no**", None: "n/a"}[ok] + f" — {text}"


def _tally(flags: Sequence[bool], what: str) -> str:
    """Verdict of a claim checked once per γ: yes (every γ), partly (some), no (none)."""
    k, n = sum(bool(f) for f in flags), len(flags)
    if k == n:
        return f"**yes** — {what} for every γ"
    return ("**partly**" if k else "**no**") + f" — {what} for {k} of {n} γ"


def _row(thesis: str, measured: str, verdict: str) -> str:
    return f"| {thesis} | {measured} | {verdict} |"


CellStats = tuple[Any, dict[str, Any]]   # (Cell, cell_stats(cell))


class Sweep:
    """What a claim sees: the cells with their stats, the GA's γ and pocket levels, and lookups."""

    def __init__(self, stats: list[CellStats]):
        self.stats = stats
        self.ga = [(c, s) for c, s in stats if c.kind == "ga"]
        self.amc = [(c, s) for c, s in stats if c.kind == "amc"]
        self.es = [(c, s) for c, s in stats if c.kind in ES_NAMES]
        self.gammas = sorted({float(c.config.get("gamma", 0)) for c, _ in self.ga})
        self.pockets = sorted({int(c.config.get("pocket", 0)) for c, _ in self.ga if c.config.get("pocket")})
        self.pocket = self.pockets[0] if self.pockets else None     # the pocket size the claims compare
        self.random = self.find("random")
        self.best_ga = max(self.ga, key=lambda cs: _mean(cs[1]["best"]), default=None)

    def find(self, kind: str, **settings: Any) -> CellStats | None:
        """The first cell of ``kind`` whose config matches ``settings``, with its stats (None: no such cell)."""
        for c, s in self.stats:
            if c.kind == kind and all(same_setting(c.config.get(k), v) for k, v in settings.items()):
                return c, s
        return None

    def ga_stats(self, **settings: Any) -> dict[str, Any] | None:
        found = self.find("ga", **settings)
        return None if found is None else found[1]

    def pairs(self, a: dict, b: dict):
        """``(gamma, stats with settings a, stats with settings b)`` for each gamma where both GA cells exist."""
        for g in self.gammas:
            s0, s1 = self.ga_stats(gamma=g, **a), self.ga_stats(gamma=g, **b)
            if s0 is not None and s1 is not None:
                yield g, s0, s1

    def pocket_pairs(self):
        """:meth:`pairs` without → with pocketing (no cross-over); none when the sweep has no pocketing."""
        if self.pocket is None:
            return iter(())
        return self.pairs({"pocket": 0, "crossover": False}, {"pocket": self.pocket, "crossover": False})

    def crossover_pairs(self):
        """:meth:`pairs` without → with cross-over (with pocketing); none when the sweep has no pocketing."""
        if self.pocket is None:
            return iter(())
        return self.pairs({"pocket": self.pocket, "crossover": False}, {"pocket": self.pocket, "crossover": True})


def pocketing_doubles_the_plateau(ctx: Sweep) -> list[str]:
    """Fig. 6.8: "Pocketing more than doubles the plateau"."""
    ratios, parts, single = [], [], []
    for g, s0, s1 in ctx.pocket_pairs():
        r = _mean(s1["plateau"]) / _mean(s0["plateau"]) if _mean(s0["plateau"]) > 0 else float("inf")
        ratios.append(r)
        # the thesis compared single trials: every (with, without) pair of seeds is one such comparison
        pair = np.asarray(s1["plateau"], float)[:, None] / np.asarray(s0["plateau"], float)[None, :]
        single.append(float(np.mean(pair > 2)))
        parts.append(f"γ={g:g}: {_mean(s0['plateau']):.3f} → {_mean(s1['plateau']):.3f} (×{r:.2f})")
    if not ratios:
        return []
    return [_row(f"Pocketing ({ctx.pocket} of N) more than doubles the plateau (Fig. 6.8)",
                 f"plateau without → with pocket: {'; '.join(parts)}; a single trial with pocketing against a single "
                 "trial without (every pair of seeds) more than doubles in "
                 + ", ".join(f"{100 * x:.0f} %" for x in single) + " of pairs",
                 _tally([r > 2 for r in ratios], f"mean ratio {min(ratios):.2f}–{max(ratios):.2f}; more than 2"))]


def pocketing_reduces_oscillation(ctx: Sweep) -> list[str]:
    """Fig. 6.8: with pocketing "the residual oscillation is much reduced, in relative terms"."""
    osc = [(_mean(s0["oscillation"]), _mean(s1["oscillation"])) for _, s0, s1 in ctx.pocket_pairs()]
    if not osc:
        return []
    return [_row("... and the residual oscillation is much reduced, in relative terms",
                 "relative oscillation (sd/mean of the best, last 50 gen.) without → with pocket: "
                 + "; ".join(f"{a:.3g} → {b:.3g}" for a, b in osc),
                 _tally([b < a for a, b in osc], "lower"))]


def large_gamma_plateaus_early(ctx: Sweep) -> list[str]:
    """Fig. 6.7: "Large γ saturates early, reaching a plateau" (with and without pocketing)."""
    if len(ctx.gammas) < 2:
        return []
    lo, hi = ctx.gammas[0], ctx.gammas[-1]
    rows = []
    for P in [0] + ctx.pockets[:1]:
        sl, sh = ctx.ga_stats(gamma=lo, pocket=P, crossover=False), ctx.ga_stats(gamma=hi, pocket=P, crossover=False)
        if sl is None or sh is None:
            continue
        early = _mean(sh["t90"]) < _mean(sl["t90"])
        lower = _mean(sh["plateau"]) < _mean(sl["plateau"])
        rows.append(_row(f"Large γ saturates early, reaching a plateau (Fig. 6.7; pocket {P})",
                         f"γ={hi:g}: t90 {_mean(sh['t90']):.0f}, plateau {_mean(sh['plateau']):.3f}; γ={lo:g}: t90 "
                         f"{_mean(sl['t90']):.0f}, plateau {_mean(sl['plateau']):.3f}",
                         _verdict(early, "plateaus earlier" + (" and lower" if lower else " (not lower)")
                                  if early else "does not plateau earlier")))
    return rows


def smaller_gamma_higher_plateau(ctx: Sweep) -> list[str]:
    """Fig. 6.7: "As γ decreases the fitness rises to higher plateaus, up to a point"."""
    if len(ctx.gammas) < 3:
        return []
    rows = []
    for P in [0] + ctx.pockets[:1]:
        found = [(g, ctx.ga_stats(gamma=g, pocket=P, crossover=False)) for g in ctx.gammas]
        found = [(g, s) for g, s in found if s is not None]
        if len(found) < 3:
            continue
        pl = [_mean(s["plateau"]) for _, s in found]
        top = found[int(np.argmax(pl))][0]
        lowest_at_max = int(np.argmin(pl)) == len(pl) - 1
        rows.append(_row(f"As γ decreases the fitness rises to higher plateaus, up to a point (Fig. 6.7; pocket {P})",
                         "plateau by γ: " + ", ".join(f"{g:g}: {p:.3f}" for (g, _), p in zip(found, pl, strict=True)),
                         _verdict(lowest_at_max, f"lowest at γ={found[-1][0]:g}, highest at γ={top:g}"
                                  if lowest_at_max else f"the largest γ is not the lowest (highest at γ={top:g})")))
    return rows


def crossover_no_gain(ctx: Sweep) -> list[str]:
    """Fig. 6.9: "Cross-over does not improve the performance over one trial"."""
    parts, better = [], []
    for g, s0, s1 in ctx.crossover_pairs():
        d = _mean(s1["plateau"]) - _mean(s0["plateau"])
        sd = float(np.sqrt((np.nanvar(s0["plateau"], ddof=1) + np.nanvar(s1["plateau"], ddof=1))
                           / max(len(s0["plateau"]), 1)))
        better.append(d > 2 * sd)
        parts.append(f"γ={g:g}: {_mean(s0['plateau']):.3f} → {_mean(s1['plateau']):.3f}")
    if not parts:
        return []
    return [_row("Cross-over does not improve the performance over one trial (Fig. 6.9)",
                 f"plateau without → with cross-over (pocket {ctx.pocket}): {'; '.join(parts)}",
                 _verdict(not any(better), "no significant gain (> 2 s.e.)" if not any(better)
                          else "cross-over is better for some γ"))]


def _crossover_compare(ctx: Sweep, metric: str) -> tuple[str, list[bool]]:
    """Per γ, ``metric`` without → with cross-over, and whether it is larger with it."""
    rows = [(g, _mean(s0[metric]), _mean(s1[metric])) for g, s0, s1 in ctx.crossover_pairs()]
    return "; ".join(f"γ={g:g}: {a:.3g} → {b:.3g}" for g, a, b in rows), [b > a for _, a, b in rows]


def crossover_keeps_oscillating(ctx: Sweep) -> list[str]:
    """Fig. 6.9: "With cross-over the fitness keeps oscillating near saturation, even for small mutation rates"."""
    text, larger = _crossover_compare(ctx, "oscillation")
    if not larger:
        return []
    return [_row("With cross-over the fitness keeps oscillating near saturation, even for small mutation rates "
                 "(Fig. 6.9)", f"relative oscillation without → with cross-over (pocket {ctx.pocket}): {text}",
                 _tally(larger, "larger with cross-over"))]


def crossover_more_diverse(ctx: Sweep) -> list[str]:
    """Ch. 6.2.4 (Fig. 6.9): "With cross-over the last generations are more varied; without it they cluster"."""
    text, more = _crossover_compare(ctx, "diversity")
    if not more:
        return []
    return [_row("With cross-over the last generations are more varied; without it they cluster around one set of "
                 "parameters (Ch. 6.2.4)", "genetic diversity (sd of a gene over the population, mean over genes, "
                 f"last generations) without → with cross-over: {text}", _tally(more, "more diverse"))]


def random_search_half_the_ga(ctx: Sweep) -> list[str]:
    """Fig. 6.10: "Random search: best ≈ half the GA's"."""
    if ctx.best_ga is None or ctx.random is None:
        return []
    (cg, sg), sr = ctx.best_ga, ctx.random[1]
    r = _mean(sg["best"]) / _mean(sr["best"])
    span = [_mean(s["best"]) for _, s in ctx.ga]
    return [_row("Random search: best ≈ half the GA's (Fig. 6.10)",
                 f"best found: GA ({cg.label()}, the best of {len(ctx.ga)} GA settings; all of them: "
                 f"{min(span):.3f}–{max(span):.3f}) {_mean(sg['best']):.3f}, random {_mean(sr['best']):.3f} "
                 f"(GA ×{r:.2f})", _verdict(1.5 <= r <= 3.0, f"ratio {r:.2f}" + ("" if 1.5 <= r <= 3.0 else
                                                                                  " (not about 2)")))]


def random_search_mean_zero(ctx: Sweep) -> list[str]:
    """Fig. 6.10: "Random search: mean fitness ≈ 0"."""
    if ctx.random is None:
        return []
    sr = ctx.random[1]
    m = _mean(sr["mean_all"])
    return [_row("Random search: mean fitness ≈ 0 (Fig. 6.10)", f"mean of all samples {_ms(sr['mean_all'])}",
                 _verdict(abs(m) < 0.02, f"{m:.4f}"))]


def adaptive_mc_positive_mean(ctx: Sweep) -> list[str]:
    """Fig. 6.11: "Adaptive MC: positive mean, unlike random search"."""
    if not ctx.amc:
        return []
    ms = [_mean(s["mean_all"]) for _, s in ctx.amc]
    pos = all(m > 0 for m in ms)
    above = ctx.random is not None and all(m > _mean(ctx.random[1]["mean_all"]) for m in ms)
    return [_row("Adaptive MC: positive mean, unlike random search (Fig. 6.11)",
                 "mean of samples: " + "; ".join(f"M={c.config.get('M')}: {m:.3f}"
                                                 for (c, _), m in zip(ctx.amc, ms, strict=True)),
                 _verdict(pos, "positive for every M" if pos else "not positive for every M")
                 + (" and above random search's" if above else ""))]


def ga_twice_the_others(ctx: Sweep) -> list[str]:
    """Fig. 6.12: "GA outperforms the other methods roughly by a factor of 2"."""
    others = ctx.amc + ([ctx.random] if ctx.random is not None else [])
    if ctx.best_ga is None or not others:
        return []
    best = _mean(ctx.best_ga[1]["best"])
    c5 = next(((c, s) for c, s in ctx.amc if c.config.get("M") == 5), None)
    best_other = max(others, key=lambda cs: _mean(cs[1]["best"]))
    r = best / _mean(best_other[1]["best"])
    txt = f"best found: GA {best:.3f}; best other ({best_other[0].label()}) {_mean(best_other[1]['best']):.3f} " \
          f"(GA ×{r:.2f})"
    if c5 is not None:
        txt += f"; AMC M=5 {_mean(c5[1]['best']):.3f} (GA ×{best / _mean(c5[1]['best']):.2f})"
    return [_row("GA outperforms the other methods roughly by a factor of 2 (Fig. 6.12)", txt,
                 _verdict(r >= 1.5, f"GA ×{r:.2f} the best other method"))]


def _best_and_single(s: dict[str, Any]) -> str:
    return f"{_ms(s['best'])} (single best {np.nanmax(s['best']):.3f})"


def ga_against_evolution_strategies(ctx: Sweep) -> list[str]:
    """Beside Fig. 6.12, not in the thesis: the best GA setting against each evosax strategy, same budget."""
    # best fitness found, mean ± sd over seeds and the thesis-style single best trial; "ahead"/"behind"
    # when the means differ by more than 2 standard errors of their difference, else "level"
    if ctx.best_ga is None or not ctx.es:
        return []
    cg, sg = ctx.best_ga
    rows = []
    for c, s in ctx.es:
        a, b = np.asarray(sg["best"], float), np.asarray(s["best"], float)
        d = _mean(a) - _mean(b)
        se = float(np.sqrt(np.nanvar(a, ddof=1) / max(len(a), 1) + np.nanvar(b, ddof=1) / max(len(b), 1))) \
            if min(len(a), len(b)) > 1 else 0.0
        word = "ahead" if d > 2 * se else "behind" if d < -2 * se else "level"
        rows.append(_row(f"(not in the thesis) The GA against {c.label()} (evosax), {s['evaluations']} evaluations",
                         f"best found, mean ± sd over seeds: GA ({cg.label()}) {_best_and_single(sg)}; "
                         f"{ES_NAMES[c.kind]} {_best_and_single(s)} (GA ×{_mean(a) / _mean(b):.2f})",
                         f"GA **{word}** — difference {d:+.3f}, 2 s.e. = {2 * se:.3f}"))
    return rows


CLAIMS: list[Callable[[Sweep], list[str]]] = [
    pocketing_doubles_the_plateau, pocketing_reduces_oscillation, large_gamma_plateaus_early,
    smaller_gamma_higher_plateau, crossover_no_gain, crossover_keeps_oscillating, crossover_more_diverse,
    random_search_half_the_ga, random_search_mean_zero, adaptive_mc_positive_mean, ga_twice_the_others,
    ga_against_evolution_strategies,
]


def _setting_rows(stats: list[CellStats]) -> list[str]:
    """The per-setting table: one row per cell."""
    rows = ["| method | setting | seeds | evaluations | best | plateau | t90 (gen) | oscillation | mean of samples |",
            "|---|---|---|---|---|---|---|---|---|"]
    for c, s in stats:
        setting = c.label() if c.kind != "ga" else (
            f"N={c.config.get('population')}, μmax={c.config.get('mu_max')}, " + c.label())
        t90 = _ms(s["t90"]) if c.kind == "ga" else "–"
        osc = _ms(s["oscillation"]) if c.kind == "ga" else "–"
        rows.append(f"| {c.kind} | {setting} | {s['seeds']} | {s['evaluations']} | {_ms(s['best'])} | "
                    f"{_ms(s['plateau'])} | {t90} | {osc} | {_ms(s['mean_all'])} |")
    return rows


def evaluation_line(files: Sequence[str]) -> str:
    """How the sweep's runs scored a controller: the thesis's one exact episode, or the robust evaluation and its
    ``--perturb`` ranges (a robust sweep's fitness is another quantity than the thesis's: compare ratios), and on
    which physics pipeline (runs that record none ran on the thesis's, springs)."""
    kinds: dict[str, int] = {}
    for p in files:
        meta = json.loads(read_attrs(p).get("meta") or "{}")      # the attributes only: no arrays read
        ev = str(meta.get("evaluation", "thesis"))
        if ev == "robust":
            pert = meta.get("perturbations") or {}
            ev = "robust (`--perturb " + ",".join(
                f"{k}={('on' if v else 'off') if isinstance(v, bool) else f'{v:g}'}" for k, v in pert.items()) + "`)"
        else:
            ev = "thesis (one exact episode per controller)"
        if meta.get("model_text"):                                 # a simulated model (not an analytic problem)
            ev += f" on the {meta.get('pipeline') or 'springs'} pipeline"
        kinds[ev] = kinds.get(ev, 0) + 1
    if len(kinds) == 1:
        return f"Evaluation: {next(iter(kinds))}."
    return "Evaluations: " + "; ".join(f"{k}: {n} runs" for k, n in kinds.items()) + "."


def provenance_lines(files: Sequence[str]) -> list[str]:
    """Where the runs came from, when it matters: more than one machine (or versions), runs still being written.
    Each line is followed by an empty one; none when every run is complete and from one machine."""
    out = []
    m = machines_line(files)
    if m:
        out += [m, ""]
    writing = [n for n in (writing_note(p) for p in files) if n]
    if writing:
        out += [f"Still going: {len(writing)} run{'s are' if len(writing) > 1 else ' is'} being written; "
                "this report reads their complete generations so far.", "",
                *[f"- {n}" for n in writing], ""]
    return out


def report(out_dir: str | os.PathLike[str]) -> str:
    """The markdown summary of a sweep: every cell (mean ± sd over seeds) and the thesis's claims checked."""
    files = [p for fs in find_runs(out_dir).values() for p in fs]
    if not files:
        raise ValueError(f"no run files under {out_dir}")
    stats = [(c, cell_stats(c)) for c in load_cells(files)]
    ctx = Sweep(stats)
    lines = [f"# Sweep report: `{os.fspath(out_dir)}`", "", evaluation_line(files), "",
             *[f"{line}" for line in provenance_lines(files)],
             f"Best = best valid fitness found in the run; plateau = GA: mean of the best of each generation "
             f"over the last {PLATEAU} generations (searches: best so far at the end); t90 = first generation at "
             "which the 10-generation running mean of the best reaches 90 % of the way from generation 0 to "
             "the plateau; oscillation = sd / mean of the best of each generation over the last 50 "
             "generations; mean = mean fitness of every sample.  All: mean ± sd over seeds.", "",
             *_setting_rows(stats),
             "", "## The thesis's claims (Ch. 6.2-6.3) against this sweep", "",
             "| thesis (Ch. 6.2-6.3) | measured here | verdict |", "|---|---|---|",
             *[row for claim in CLAIMS for row in claim(ctx)]]
    return "\n".join(lines) + "\n"


def write_report(out_dir: str | os.PathLike[str], out: str | os.PathLike[str] | None = None) -> str:
    """:func:`report` written to ``out`` (default ``OUT/report.md``); returns the text."""
    text = report(out_dir)
    path = os.fspath(out) if out is not None else os.path.join(os.fspath(out_dir), "report.md")
    with open(path, "w") as f:
        f.write(text)
    return text
