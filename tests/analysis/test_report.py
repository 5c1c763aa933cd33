"""The sweep report (``cpgjax report``): one named function per thesis claim, each checked on a tiny sweep."""

import inspect

import pytest
from runcases import TINY_SWEEP, other_machine

from cpgjax.analysis import report as rep
from cpgjax.cli import main

CLAIM_NAMES = ["pocketing_doubles_the_plateau", "pocketing_reduces_oscillation", "large_gamma_plateaus_early",
               "smaller_gamma_higher_plateau", "crossover_no_gain", "crossover_keeps_oscillating",
               "crossover_more_diverse", "random_search_half_the_ga", "random_search_mean_zero",
               "adaptive_mc_positive_mean", "ga_twice_the_others", "ga_against_evolution_strategies"]
# the claim that needs three γ; the tiny sweep has two
NEEDS_THREE_GAMMAS = {"smaller_gamma_higher_plateau"}


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep") / "tiny"
    main([*TINY_SWEEP, "--generations", "6", "--out", str(out)])      # one program with experiments/test_sweep.py
    return out


def test_one_named_function_per_claim():
    assert [f.__name__ for f in rep.CLAIMS] == CLAIM_NAMES
    for f in rep.CLAIMS:
        assert getattr(rep, f.__name__) is f
        doc = inspect.getdoc(f)
        assert doc and "\n" not in doc and ("Fig." in doc or "Ch." in doc), f.__name__


def test_each_claim_returns_rows_or_nothing(sweep):
    ctx = rep.Sweep([(c, rep.cell_stats(c)) for c in rep.load_cells(
        [p for fs in rep.find_runs(sweep).values() for p in fs])])
    text = rep.report(sweep)
    for claim in rep.CLAIMS:
        rows = claim(ctx)
        assert isinstance(rows, list) and all(isinstance(r, str) for r in rows), claim.__name__
        if claim.__name__ in NEEDS_THREE_GAMMAS:
            assert rows == []
            continue
        assert rows, claim.__name__
        for row in rows:
            assert row.startswith("| ") and row.endswith(" |") and row.count(" | ") >= 2
            assert f"\n{row}\n" in text, claim.__name__
    # and a sweep with none of the cells a claim needs gives no rows
    empty = rep.Sweep([])
    assert all(claim(empty) == [] for claim in rep.CLAIMS)


def test_report_has_the_table_and_every_claim(sweep):
    text = rep.report(sweep)
    assert text.startswith(f"# Sweep report: `{sweep}`\n\nEvaluation: thesis (one exact episode per controller).\n")
    assert "| ga | N=6, μmax=" in text and "| random |" in text and "| amc |" in text
    for needle in ["Pocketing (2 of N) more than doubles the plateau", "residual oscillation is much reduced",
                   "Large γ saturates early, reaching a plateau (Fig. 6.7; pocket 0)",
                   "Large γ saturates early, reaching a plateau (Fig. 6.7; pocket 2)",
                   "Cross-over does not improve", "keeps oscillating near saturation",
                   "last generations are more varied", "Random search: best ≈ half the GA's",
                   "Random search: mean fitness ≈ 0", "Adaptive MC: positive mean", "GA outperforms the other methods"]:
        assert needle in text
    assert rep.write_report(sweep) == (sweep / "report.md").read_text() == text


def test_the_report_says_when_runs_came_from_more_than_one_machine(sweep):
    import json

    import h5py

    from cpgjax.io.sweepdir import find_runs

    assert "Machines:" not in rep.report(sweep)
    files = [p for fs in find_runs(sweep).values() for p in fs]
    with h5py.File(files[0], "a") as f:
        old = f.attrs["machines"]
        m = json.loads(old)
        other = other_machine()["cpu"]
        m[-1]["cpu"] = other
        f.attrs["machines"] = json.dumps(m)
    try:
        text = rep.report(sweep)
        line = next(x for x in text.splitlines() if x.startswith("Machines:"))
        assert "2 machines" in line and other in line and "1 run;" in line
    finally:
        with h5py.File(files[0], "a") as f:
            f.attrs["machines"] = old
