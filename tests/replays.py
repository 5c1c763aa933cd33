"""Claims of what a controller does ("walks +1.32 m in 10 s, stays up"), checked by replaying it with
``cpgjax simulate``: the README's GIF rows (tests/test_figures.py) and the headers of the shipped controllers
(tests/test_models.py)."""

from __future__ import annotations

import re

from cpgjax import cli

# A claim's distance is written with two decimals (half a unit: 0.005 m) and varies across CPUs by the spread
# tests/test_readme.py measured on the trot (1.4 %, its tolerance 3 %): both together.
RTOL, ATOL = 0.03, 0.005
CLAIM = re.compile(r"(?P<verb>[a-z]+) (?P<dist>[-+]\d+\.\d\d) m(?P<what>[^,]*), (?P<fall>stays up|falls)$")
SIMULATE_TAKES = ("--ctl", "--time", "--terrain", "--pipeline", "--dt", "--gravity", "--delta")


def replay(argv: list[str], capsys) -> tuple[float, bool]:
    """Distance and fall of ``cpgjax simulate ARGV`` (options simulate does not take are dropped with their
    value: a ``cpgjax render`` command line replays as the episode it draws)."""
    keep, i = [], 0
    while i < len(argv):
        if argv[i].startswith("--") and argv[i] not in SIMULATE_TAKES:
            i += 2
            continue
        keep.append(argv[i])
        i += 1
    capsys.readouterr()
    assert cli.main(["simulate", *keep]) == 0
    out = capsys.readouterr().out
    dist = float(re.search(r"^distance\s+([-+]\d+\.\d+) m", out, re.M).group(1))
    fell = re.search(r"^fallen\s+(yes|no)", out, re.M).group(1) == "yes"
    return dist, fell


def check(claim: str, dist: float, fell: bool, name: str, fix: str) -> None:
    """``claim`` holds for an episode that went ``dist`` metres and fell or not; ``fix`` says how to update it."""
    m = CLAIM.match(claim)
    assert m, f"{name}: the claim should read 'VERB +D.DD m[ …], stays up|falls': {claim!r}"
    want = float(m["dist"])
    assert abs(dist - want) <= RTOL * abs(want) + ATOL, (
        f"{name}: the controller now goes {dist:+.3f} m, the claim says {want:+.2f} m: {fix}")
    now = "falls" if fell else "stays up"
    assert now == m["fall"], f"{name}: the claim says it {m['fall']}, it now {now}: {fix}"


def updated(claim: str, dist: float, fell: bool) -> str:
    """``claim`` rewritten for an episode that went ``dist`` metres and fell or not."""
    m = CLAIM.match(claim)
    return f"{m['verb']} {dist:+.2f} m{m['what']}, {'falls' if fell else 'stays up'}"
