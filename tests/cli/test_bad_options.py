"""Bad option values a newcomer met (issue 51, "The front door"): one line naming the problem, exit code 2, nothing
written.

``--perturb`` (a key twice, a latency that is not 0 or 1, a flag that is not on or off, sensor ranges the open-loop
CPG cannot feel), ``--controller`` with an empty list of sensor groups, the advice to start anew with
``--overwrite`` only from the commands that have it, and a ``--resume`` that names the setting that differs (the
controller, the starting controller, the perturbation ranges) rather than the genome's size.  Every row fails
before any simulation: the run files are made without a generation (no episode is simulated).
"""

from __future__ import annotations

import os

import jax
import pytest
from runcases import one_line_error

from cpgjax.cli import main
from cpgjax.experiments.runner import open_run, run_keys
from cpgjax.optim.algorithm import make_algorithm
from cpgjax.optim.factory import make_problem
from cpgjax.optim.ga import GAConfig

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
M = os.path.join(ROOT, "models", "quadruped.wl")
CTL = os.path.join(ROOT, "models", "quadruped-trot.ctl")
ROBUST = ["--evaluation", "robust", "--perturb"]


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """Run files with no generation yet (a CPG run, a closed-loop one, a robust one), a truncated one, not HDF5."""
    d = tmp_path_factory.mktemp("options")
    for name, kw in (("cpg.h5", {}), ("pmtg.h5", {"controller": "pmtg"}),
                     ("robust.h5", {"evaluation": "robust", "perturb": {"lift": 0.01}})):
        problem = make_problem(M, time=0.3, **kw)
        algo = make_algorithm(problem, GAConfig(population=4, generations=3))
        params = jax.tree.map(jax.numpy.asarray, algo.params)
        open_run(problem, algo, str(d / name), params, run_keys(0)[0], resume=False, overwrite=False, metrics={})
    data = (d / "cpg.h5").read_bytes()
    (d / "trunc.h5").write_bytes(data[: len(data) // 3])
    (d / "notrun.h5").write_text("not HDF5\n")
    return d


def _files(d) -> dict[str, bytes]:
    return {os.path.relpath(os.path.join(r, f), d): open(os.path.join(r, f), "rb").read()
            for r, _, files in os.walk(d) for f in files}


EVOLVE = ["evolve", M, "--out", "o.h5", "--quiet"]
ROWS = [
    # --perturb
    ("perturb-key-twice", [*EVOLVE, *ROBUST, "latency=1,latency=0"],
     ["--perturb", "latency is given twice in 'latency=1,latency=0'"], []),
    ("perturb-latency-1.5", [*EVOLVE, *ROBUST, "latency=1.5"],
     ["--perturb", "latency: expected 0 or 1", "'1.5'"], ["a number"]),
    ("perturb-latency-2", [*EVOLVE, *ROBUST, "latency=2"], ["latency: expected 0 or 1"], []),
    ("perturb-worst-minus", [*EVOLVE, *ROBUST, "worst=-1"], ["worst: expected a whole number >= 0", "'-1'"], []),
    ("perturb-worst-over", [*EVOLVE, *ROBUST, "replicas=2,worst=3"], ["perturbation worst", "0 (all) to 2, got 3"],
     []),
    ("perturb-fall-tilt-10", [*EVOLVE, *ROBUST, "fall_tilt=10"],
     ["perturbation fall_tilt", "from 20 to 60", "got 10"], []),
    ("perturb-turn-tolerance-no-command", [*EVOLVE, *ROBUST, "turn_tolerance=1"],
     ["perturbation turn_tolerance", "give command too"], []),
    ("perturb-flag-maybe", [*EVOLVE, *ROBUST, "fall_zero=maybe"], ["fall_zero: expected on or off", "'maybe'"], []),
    ("perturb-replicas-2.5", [*EVOLVE, *ROBUST, "replicas=2.5"], ["replicas: expected a whole number >= 1"], []),
    ("perturb-lift-negative", [*EVOLVE, *ROBUST, "lift=-1"], ["lift: expected a finite number >= 0", "'-1'"], []),
    ("perturb-latency-cpg", [*EVOLVE, *ROBUST, "latency=1"], ["perturbation latency", "open-loop CPG"], []),
    ("perturb-noise-cpg", [*EVOLVE, *ROBUST, "noise=0.02"], ["perturbation noise", "open-loop CPG"], []),
    ("perturb-noise-cpg-explicit", [*EVOLVE, "--controller", "cpg", *ROBUST, "preset=domain,noise=0.02"],
     ["perturbation noise", "open-loop CPG"], []),
    ("perturb-noise-cpg-search", ["search", M, "--out", "s.h5", *ROBUST, "noise=0.02"], ["perturbation noise"], []),
    ("perturb-noise-cpg-sweep", ["sweep", M, "--out", "sw", "--generations", "1", "--seeds", "1", *ROBUST,
                                 "noise=0.02"], ["perturbation noise"], []),
    ("perturb-command-cpg", [*EVOLVE, *ROBUST, "command=0.3"], ["perturbation command"], []),
    # --controller
    ("controller-empty-groups", [*EVOLVE, "--controller", "pmtg::mirror"],
     ["--controller", "'pmtg::mirror'", "empty list of sensor groups"], []),
    ("controller-colon-only", [*EVOLVE, "--controller", "pmtg:"], ["'pmtg:'", "empty list of sensor groups"], []),
    # --overwrite is advised only by the commands that have it
    ("best-truncated", ["best", "trunc.h5"], ["trunc.h5", "not a readable cpgjax run"], ["--overwrite"]),
    ("best-not-hdf5", ["best", "notrun.h5"], ["notrun.h5", "not a readable cpgjax run"], ["--overwrite"]),
    ("transfer-truncated", ["transfer", "trunc.h5"], ["trunc.h5", "not a readable cpgjax run"], ["--overwrite"]),
    ("transfer-not-hdf5", ["transfer", "notrun.h5"], ["notrun.h5", "not a readable cpgjax run"], ["--overwrite"]),
    ("plot-truncated", ["plot", "trunc.h5", "--out", "p.png"], ["trunc.h5"], ["--overwrite"]),
    ("adapt-not-hdf5", ["adapt", M, "--repertoire", "notrun.h5", "--damage", "leg=AR"], ["notrun.h5"],
     ["--overwrite"]),
    ("resume-truncated", ["evolve", M, "--out", "trunc.h5", "--resume", "--quiet"],
     ["trunc.h5", "not a readable cpgjax run", "start anew with --overwrite"], []),
    ("repertoire-resume-not-hdf5", ["repertoire", M, "--out", "notrun.h5", "--resume", "--quiet"],
     ["notrun.h5", "start anew with --overwrite"], []),
    # --resume names what differs
    ("resume-other-controller", ["evolve", M, "--out", "cpg.h5", "--resume", "--controller", "pmtg:tilt+bias",
                                 "--quiet"],
     ["cpg.h5: cannot resume: --controller pmtg:tilt+bias differs from the run's cpg"], ["genes"]),
    ("resume-cpg-over-pmtg", ["evolve", M, "--out", "pmtg.h5", "--resume", "--controller", "cpg", "--quiet"],
     ["pmtg.h5: cannot resume: --controller cpg differs from the run's pmtg"], ["genes"]),
    ("resume-mirror", ["evolve", M, "--out", "pmtg.h5", "--resume", "--controller", "pmtg:mirror", "--quiet"],
     ["--controller pmtg:mirror differs from the run's pmtg"], ["genes"]),
    ("resume-other-start", ["evolve", M, "--out", "cpg.h5", "--resume", "--start", CTL, "--quiet"],
     [f"--start {CTL} differs from the run's none"], []),
    ("resume-other-perturb", ["evolve", M, "--out", "robust.h5", "--resume", "--perturb", "lift=0.02", "--quiet"],
     ["--perturb lift=0.02 differs from the run's lift=0.01"], []),
    ("resume-ga-as-search", ["search", M, "--out", "cpg.h5", "--resume", "--quiet"],
     ["cpg.h5: cannot resume: it holds a GA run, not a 'random' one"], []),
    ("resume-other-evaluation", ["evolve", M, "--out", "cpg.h5", "--resume", "--evaluation", "robust", "--quiet"],
     ["--evaluation robust differs from the run's thesis"], []),
]


@pytest.mark.parametrize("argv,expect,absent", [pytest.param(a, e, n, id=i) for i, a, e, n in ROWS])
def test_bad_option_is_one_line_exit_2_and_writes_nothing(folder, monkeypatch, capsys, argv, expect, absent):
    monkeypatch.chdir(folder)
    before = _files(folder)
    rc = main(argv)
    err = capsys.readouterr().err
    assert rc == 2, err
    one_line_error(err, argv[0], expect, absent)
    assert _files(folder) == before


def test_a_resume_with_another_method_names_it(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["search", "analytic:sphere:4", "--out", "s.h5", "--samples", "40", "--quiet"]) == 0
    capsys.readouterr()
    assert main(["search", "analytic:sphere:4", "--out", "s.h5", "--method", "amc", "--resume", "--quiet"]) == 2
    assert "s.h5: cannot resume: --method amc differs from the run's random" in capsys.readouterr().err


def test_good_perturbations_still_parse():
    from cpgjax.cli.options import perturbations

    assert perturbations("preset=domain,bristle=2,fall_zero=off,fall_survival=yes,latency=0,replicas=8") == {
        "preset": "domain", "bristle": 2.0, "fall_zero": False, "fall_survival": True, "latency": 0, "replicas": 8}
