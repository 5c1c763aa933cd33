"""The four example robots of Appendix A do what the thesis describes, and every shipped controller does what its
header says."""

import glob
import os
import re
import shlex

import numpy as np
import pytest
from replays import check, check_walk, replay, replay_walk

from cpgjax.analysis.contacts import feet_down
from cpgjax.episode.batch import simulate
from cpgjax.io.ctl import read_ctl
from cpgjax.io.wl import load_model

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(name, ctl=True, record=False, time=None):
    m = load_model(f"models/{name}.wl")
    c = read_ctl(f"models/{name}.ctl", n_dof=m.n_ctrl, harmonics=m.episode.harmonics).coeffs if ctl else \
        np.zeros((m.n_ctrl, m.n_coeff))
    return m, simulate(m, c, record=record, **({} if time is None else {"time": time}))


def test_quadruped_matches_appendix_c():
    m = load_model("models/quadruped.wl")
    assert m.total_mass == pytest.approx(13.8)
    assert m.n_ctrl == 8 and m.n_genes == 40 and m.mu_static == 2.5
    assert np.allclose(m.j_lo, -1.5) and np.allclose(m.j_hi, 1.5)


def test_grip_is_the_quadruped_with_feet_that_grip():
    """models/quadruped-grip.wl is models/quadruped.wl, line for line, but for its header and one line: a friction
    bristle 100 times stiffer and 10 times more damped than the default (sim.model's DEFAULT_FRICTION_K, _B)."""
    def body(name):
        return [ln for ln in open(f"models/{name}.wl").read().splitlines() if ln.strip() and not ln.startswith("#")]
    grip, quad = body("quadruped-grip"), body("quadruped")
    extra = [ln for ln in grip if ln.startswith("FrictionSpring")]
    assert len(extra) == 1 and [ln for ln in grip if ln not in extra] == quad
    g, q = load_model("models/quadruped-grip.wl"), load_model("models/quadruped.wl")
    assert (g.friction_k, g.friction_b) == (100 * q.friction_k, 10 * q.friction_b) == (1e5, 3000)


@pytest.mark.slow  # 12 s, its 0.1 ms step
def test_car_rolls_down_its_ramp():
    """1.5 s of its 3.5 s episode (0.1 ms steps: the slowest example).  Rolling without slipping down the
    0.2 rad ramp it would cover (g sin 0.2) t^2 / 2 / (1 + I_wheels / (m r^2)) = 2.2 m / (1 + ...) in 1.5 s."""
    m, r = run("car", ctl=False, record=True, time=1.5)
    assert m.n_ctrl == 0 and m.nj == 4
    free_slide = 9.81 * np.sin(0.2) * 1.5**2 / 2
    assert 0.4 * free_slide < r["distance"] < free_slide and not r["fallen"] and not r["diverged"]
    z = r["traj"]["x"][:, 2, m.track]
    assert z[-1] < z[0] - 0.4 * free_slide * np.sin(0.2)  # it went down the ramp


@pytest.mark.slow  # fast: test_figures.py replays the worm's controller
def test_worm_crawls():
    m, r = run("worm")
    assert m.n_ctrl == 4
    assert r["distance"] > 0.2 and not r["diverged"]


@pytest.mark.slow  # fast: test_figures.py replays the hexapod's controller
def test_hexapod_walks_with_a_tripod_gait():
    m, r = run("hexapod", record=True)
    assert m.n_ctrl == 12
    assert r["distance"] > 0.4 and not r["fallen"] and not r["diverged"]
    t = r["traj"]["t"] > 1
    a = feet_down(m, r["traj"], ["LoAR", "LoCL", "LoPR"], tol=3e-3)[t]
    b = feet_down(m, r["traj"], ["LoAL", "LoCR", "LoPL"], tol=3e-3)[t]
    assert np.mean(a + b >= 3) > 0.8  # mostly three or more feet down
    assert np.corrcoef(a, b)[0, 1] < -0.3  # the two tripods alternate


# Every shipped controller says in its header how it was made and what it does with today's code, one line per
# replay: "#   cpgjax simulate ARGS  ->  CLAIM", and for a steering controller "#   cpgjax follow ARGS  ->  CLAIM".
# Each line is replayed here (the quadruped's springs lines share one compiled program with the README's example,
# the 6 s lines with tests/test_figures.py's GIF replays).
HEADER_LINE = re.compile(r"^#\s+cpgjax (?P<args>(?:simulate|follow) .+?)\s+->\s+(?P<claim>.+?)\s*$", re.M)
CONTROLLERS = sorted(glob.glob(os.path.join(ROOT, "models", "*.ctl")))


def header_claims(path: str) -> list[tuple[str, str]]:
    header = "".join(line for line in open(path) if line.startswith("#"))
    return [(m["args"], m["claim"]) for m in HEADER_LINE.finditer(header)]


def test_every_shipped_controller_has_a_header_that_says_how_it_was_made_and_what_it_does():
    assert CONTROLLERS
    for path in CONTROLLERS:
        claims = header_claims(path)
        assert claims, f"{path}: its header has no '#   cpgjax simulate ARGS  ->  CLAIM' line"
        name = os.path.basename(path)
        for args, _ in claims:
            assert f"--ctl models/{name}" in args, f"{path}: a header line replays another controller: {args}"


def exact(path: str, args: str) -> bool:
    """The line replays on exact joints: said, or its controller's header's pipeline."""
    return "--pipeline exact" in args or read_ctl(path).header.setting("pipeline") == "exact"


# The exact pipeline's lines compile a program of their own (15-25 s of CPU each): marked slow (make test-slow).
@pytest.mark.parametrize("path,args,claim", [
    pytest.param(p, a, c, id=f"{os.path.basename(p)}:{' '.join(a.split()[4:]) or 'default'}",
                 marks=[pytest.mark.slow] if exact(p, a) else [])
    for p in CONTROLLERS for a, c in header_claims(p)])
def test_each_shipped_controller_does_what_its_header_says(path, args, claim, capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    command, *argv = shlex.split(args)
    if command == "follow":
        check_walk(claim, replay_walk(argv, capsys), f"{path}: '{args}'", "replay it and update the header line")
        return
    dist, fell = replay(argv, capsys)
    check(claim, dist, fell, f"{path}: '{args}'", "replay it and update the header line")
