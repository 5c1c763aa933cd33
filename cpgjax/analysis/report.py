"""The summary of a sweep and the thesis's claims checked against it (``cpgjax report``)."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from cpgjax.analysis.cells import load_cells
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


def report(out_dir: str | os.PathLike[str]) -> str:
    """The markdown summary of a sweep: every cell (mean ± sd over seeds) and the thesis's claims checked."""
    files = [p for fs in find_runs(out_dir).values() for p in fs]
    if not files:
        raise ValueError(f"no run files under {out_dir}")
    cells = load_cells(files)
    stats = [(c, cell_stats(c)) for c in cells]
    lines = [f"# Sweep report: `{os.fspath(out_dir)}`", "",
             f"Best = best valid fitness found in the run; plateau = GA: mean of the best of each generation "
             f"over the last {PLATEAU} generations (searches: best so far at the end); t90 = first generation at "
             "which the 10-generation running mean of the best reaches 90 % of the way from generation 0 to "
             "the plateau; oscillation = sd / mean of the best of each generation over the last 50 "
             "generations; mean = mean fitness of every sample.  All: mean ± sd over seeds.", "",
             "| method | setting | seeds | evaluations | best | plateau | t90 (gen) | oscillation | mean of samples |",
             "|---|---|---|---|---|---|---|---|---|"]
    for c, s in stats:
        setting = c.label() if c.kind != "ga" else (
            f"N={c.config.get('population')}, μmax={c.config.get('mu_max')}, " + c.label())
        t90 = _ms(s["t90"]) if c.kind == "ga" else "–"
        osc = _ms(s["oscillation"]) if c.kind == "ga" else "–"
        lines.append(f"| {c.kind} | {setting} | {s['seeds']} | {s['evaluations']} | {_ms(s['best'])} | "
                     f"{_ms(s['plateau'])} | {t90} | {osc} | {_ms(s['mean_all'])} |")

    def find(kind, **kw):
        for c, s in stats:
            if c.kind == kind and all(same_setting(c.config.get(k), v) for k, v in kw.items()):
                return c, s
        return None, None

    def pairs(a: dict, b: dict):
        """``(gamma, stats with settings a, stats with settings b)`` for each gamma where both GA cells exist."""
        for g in gammas:
            s0, s1 = find("ga", gamma=g, **a)[1], find("ga", gamma=g, **b)[1]
            if s0 is not None and s1 is not None:
                yield g, s0, s1

    claims = ["", "## The thesis's claims (Ch. 6.2-6.3) against this sweep", "",
              "| thesis (Ch. 6.2-6.3) | measured here | verdict |", "|---|---|---|"]
    ga_cells = [(c, s) for c, s in stats if c.kind == "ga"]
    gammas = sorted({float(c.config.get("gamma", 0)) for c, _ in ga_cells})
    pockets = sorted({int(c.config.get("pocket", 0)) for c, _ in ga_cells if c.config.get("pocket")})
    # 1. pocketing doubles the plateau; 2. less relative oscillation
    if pockets:
        P = pockets[0]
        ratios, osc0, osc1, parts, single = [], [], [], [], []
        for g, s0, s1 in pairs({"pocket": 0, "crossover": False}, {"pocket": P, "crossover": False}):
            r = _mean(s1["plateau"]) / _mean(s0["plateau"]) if _mean(s0["plateau"]) > 0 else float("inf")
            ratios.append(r)
            # the thesis compared single trials: every (with, without) pair of seeds is one such comparison
            pair = np.asarray(s1["plateau"], float)[:, None] / np.asarray(s0["plateau"], float)[None, :]
            single.append(float(np.mean(pair > 2)))
            osc0.append(_mean(s0["oscillation"]))
            osc1.append(_mean(s1["oscillation"]))
            parts.append(f"γ={g:g}: {_mean(s0['plateau']):.3f} → {_mean(s1['plateau']):.3f} (×{r:.2f})")
        if ratios:
            claims.append(f"| Pocketing ({P} of N) more than doubles the plateau (Fig. 6.8) | plateau without → with "
                          f"pocket: {'; '.join(parts)}"
                          + "; a single trial with pocketing against a single trial without (every pair of seeds) "
                          "more than doubles in " + ", ".join(f"{100 * x:.0f} %" for x in single) + " of pairs | "
                          + _tally([r > 2 for r in ratios], f"mean ratio {min(ratios):.2f}–{max(ratios):.2f}; more "
                                   "than 2") + " |")
            claims.append("| ... and the residual oscillation is much reduced, in relative terms | relative "
                          "oscillation (sd/mean of the best, last 50 gen.) without → with pocket: "
                          + "; ".join(f"{a:.3g} → {b:.3g}" for a, b in zip(osc0, osc1, strict=True)) + " | "
                          + _tally([b < a for a, b in zip(osc0, osc1, strict=True)], "lower") + " |")
    # 3. large gamma plateaus early
    if len(gammas) > 1:
        lo, hi = gammas[0], gammas[-1]
        for P in [0] + pockets[:1]:
            cl, sl = find("ga", gamma=lo, pocket=P, crossover=False)
            ch, sh = find("ga", gamma=hi, pocket=P, crossover=False)
            if cl is None or ch is None:
                continue
            early = _mean(sh["t90"]) < _mean(sl["t90"])
            lower = _mean(sh["plateau"]) < _mean(sl["plateau"])
            claims.append(f"| Large γ saturates early, reaching a plateau (Fig. 6.7; pocket {P}) | γ={hi:g}: t90 "
                          f"{_mean(sh['t90']):.0f}, plateau {_mean(sh['plateau']):.3f}; γ={lo:g}: t90 "
                          f"{_mean(sl['t90']):.0f}, plateau {_mean(sl['plateau']):.3f} | "
                          + _verdict(early, "plateaus earlier" + (" and lower" if lower else " (not lower)")
                                     if early else "does not plateau earlier") + " |")
    # 3b. smaller gamma, higher plateau (up to a point)
    if len(gammas) > 2:
        for P in [0] + pockets[:1]:
            found = [(g, find("ga", gamma=g, pocket=P, crossover=False)[1]) for g in gammas]
            found = [(g, s) for g, s in found if s is not None]
            if len(found) < 3:
                continue
            pl = [_mean(s["plateau"]) for _, s in found]
            top = found[int(np.argmax(pl))][0]
            lowest_at_max = int(np.argmin(pl)) == len(pl) - 1
            claims.append("| As γ decreases the fitness rises to higher plateaus, up to a point "
                          f"(Fig. 6.7; pocket {P}) | "
                          "plateau by γ: " + ", ".join(f"{g:g}: {p:.3f}" for (g, _), p in zip(found, pl, strict=True))
                          + " | " + _verdict(lowest_at_max, f"lowest at γ={found[-1][0]:g}, highest at γ={top:g}"
                                             if lowest_at_max else f"the largest γ is not the lowest (highest at "
                                             f"γ={top:g})") + " |")
    # 4. cross-over does not improve the performance within one trial
    if pockets:
        P = pockets[0]
        parts, better = [], []
        for g, s0, s1 in pairs({"pocket": P, "crossover": False}, {"pocket": P, "crossover": True}):
            d = _mean(s1["plateau"]) - _mean(s0["plateau"])
            sd = float(np.sqrt((np.nanvar(s0["plateau"], ddof=1) + np.nanvar(s1["plateau"], ddof=1))
                               / max(len(s0["plateau"]), 1)))
            better.append(d > 2 * sd)
            parts.append(f"γ={g:g}: {_mean(s0['plateau']):.3f} → {_mean(s1['plateau']):.3f}")
        if parts:
            claims.append("| Cross-over does not improve the performance over one trial (Fig. 6.9) | plateau "
                          f"without → with cross-over (pocket {P}): {'; '.join(parts)} | "
                          + _verdict(not any(better), "no significant gain (> 2 s.e.)" if not any(better)
                                     else "cross-over is better for some γ") + " |")
    # 4b. cross-over keeps oscillating near saturation even with a small mutation rate; more diverse populations
    if pockets:
        P = pockets[0]
        without, with_ = {"pocket": P, "crossover": False}, {"pocket": P, "crossover": True}

        def compare(metric: str) -> tuple[str, list[bool]]:
            """Per γ, ``metric`` without → with cross-over, and whether it is larger with it."""
            rows = [(g, _mean(s0[metric]), _mean(s1[metric])) for g, s0, s1 in pairs(without, with_)]
            return "; ".join(f"γ={g:g}: {a:.3g} → {b:.3g}" for g, a, b in rows), [b > a for _, a, b in rows]

        text, larger = compare("oscillation")
        if larger:
            claims.append("| With cross-over the fitness keeps oscillating near saturation, even for small mutation "
                          f"rates (Fig. 6.9) | relative oscillation without → with cross-over (pocket {P}): "
                          f"{text} | " + _tally(larger, "larger with cross-over") + " |")
        text, more = compare("diversity")
        if more:
            claims.append("| With cross-over the last generations are more varied; without it they cluster around "
                          "one set of parameters (Ch. 6.2.4) | genetic diversity (sd of a gene over the population, "
                          f"mean over genes, last generations) without → with cross-over: {text} | "
                          + _tally(more, "more diverse") + " |")
    # 5-8. baselines
    best_ga = max(ga_cells, key=lambda cs: _mean(cs[1]["best"]), default=(None, None))
    cr, sr = find("random")
    if best_ga[0] is not None and cr is not None:
        r = _mean(best_ga[1]["best"]) / _mean(sr["best"])
        span = [_mean(s["best"]) for _, s in ga_cells]
        claims.append(f"| Random search: best ≈ half the GA's (Fig. 6.10) | best found: GA ({best_ga[0].label()}, "
                      f"the best of {len(ga_cells)} GA settings; all of them: {min(span):.3f}–{max(span):.3f}) "
                      f"{_mean(best_ga[1]['best']):.3f}, random {_mean(sr['best']):.3f} (GA ×{r:.2f}) | "
                      + _verdict(1.5 <= r <= 3.0, f"ratio {r:.2f}" + ("" if 1.5 <= r <= 3.0 else
                                 " (not about 2)")) + " |")
    if cr is not None:
        m = _mean(sr["mean_all"])
        claims.append(f"| Random search: mean fitness ≈ 0 (Fig. 6.10) | mean of all samples {_ms(sr['mean_all'])} | "
                      + _verdict(abs(m) < 0.02, f"{m:.4f}") + " |")
    amcs = [(c, s) for c, s in stats if c.kind == "amc"]
    if amcs:
        ms = [_mean(s["mean_all"]) for _, s in amcs]
        pos = [m > 0 for m in ms]
        above = cr is not None and all(m > _mean(sr["mean_all"]) for m in ms)
        claims.append("| Adaptive MC: positive mean, unlike random search (Fig. 6.11) | mean of samples: "
                      + "; ".join(f"M={c.config.get('M')}: {m:.3f}" for (c, _), m in zip(amcs, ms, strict=True))
                      + " | " + _verdict(all(pos), "positive for every M" if all(pos) else "not positive for every M")
                      + (" and above random search's" if above else "") + " |")
    if best_ga[0] is not None and (amcs or cr is not None):
        others = amcs + ([(cr, sr)] if cr is not None else [])
        c5 = next(((c, s) for c, s in amcs if c.config.get("M") == 5), None)
        best_other = max(others, key=lambda cs: _mean(cs[1]["best"]))
        r = _mean(best_ga[1]["best"]) / _mean(best_other[1]["best"])
        txt = f"best found: GA {_mean(best_ga[1]['best']):.3f}; best other ({best_other[0].label()}) " \
              f"{_mean(best_other[1]['best']):.3f} (GA ×{r:.2f})"
        if c5 is not None:
            txt += f"; AMC M=5 {_mean(c5[1]['best']):.3f} (GA ×{_mean(best_ga[1]['best']) / _mean(c5[1]['best']):.2f})"
        claims.append(f"| GA outperforms the other methods roughly by a factor of 2 (Fig. 6.12) | {txt} | "
                      + _verdict(r >= 1.5, f"GA ×{r:.2f} the best other method") + " |")
    return "\n".join(lines + claims) + "\n"


def write_report(out_dir: str | os.PathLike[str], out: str | os.PathLike[str] | None = None) -> str:
    """:func:`report` written to ``out`` (default ``OUT/report.md``); returns the text."""
    text = report(out_dir)
    path = os.fspath(out) if out is not None else os.path.join(os.fspath(out_dir), "report.md")
    with open(path, "w") as f:
        f.write(text)
    return text
