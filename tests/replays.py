"""Claims of what a controller does ("walks +1.32 m in 10 s, stays up"), checked by replaying it with
``cpgjax simulate``: the README's GIF rows (tests/test_figures.py) and the headers of the shipped controllers
(tests/test_models.py); and of how a steering controller walks a path ("finished in 42.6 s, waypoints 32 of 32"),
checked by replaying it with ``cpgjax follow``."""

from __future__ import annotations

import re

from cpgjax import cli

# A claim's distance is written with two decimals (half a unit: 0.005 m) and varies across CPUs by the spread
# tests/test_readme.py measured on the trot (1.4 %, its tolerance 3 %): both together.
RTOL, ATOL = 0.03, 0.005
# A claim may state its own tolerance, measured across CPUs and vector units where a chaotic walk parts on them
# ("walks +2.32 ±0.19 m in 10 s": an AMD EPYC and an Intel Xeon, each with AVX-512, AVX2 and SSE4.2, gave +2.15 to
# +2.50 m): then that, not RTOL, applies.
CLAIM = re.compile(r"(?P<verb>[a-z]+) (?P<dist>[-+]\d+\.\d\d)(?: ±(?P<tol>\d+\.\d+))? m(?P<what>[^,]*), "
                   r"(?P<fall>stays up|falls)$")
SIMULATE_TAKES = ("--ctl", "--time", "--terrain", "--pipeline", "--dt", "--gravity", "--delta", "--engine",
                  "--mujoco-dt")


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
    assert m, f"{name}: the claim should read 'VERB +D.DD [±T] m[ …], stays up|falls': {claim!r}"
    want = float(m["dist"])
    tol = RTOL * abs(want) + ATOL if m["tol"] is None else float(m["tol"])
    assert abs(dist - want) <= tol, (
        f"{name}: the controller now goes {dist:+.3f} m, the claim says {want:+.2f} m: {fix}")
    now = "falls" if fell else "stays up"
    assert now == m["fall"], f"{name}: the claim says it {m['fall']}, it now {now}: {fix}"


def updated(claim: str, dist: float, fell: bool) -> str:
    """``claim`` rewritten for an episode that went ``dist`` metres and fell or not."""
    m = CLAIM.match(claim)
    tol = "" if m["tol"] is None else f" ±{m['tol']}"
    return f"{m['verb']} {dist:+.2f}{tol} m{m['what']}, {'falls' if fell else 'stays up'}"


# A walk's claim: how it ended (the time to a tenth of a second) and the waypoints it passed, as `cpgjax follow`
# prints them.  The time within the distance's tolerance (RTOL) and half a tenth, or the claim's own ("finished in
# 43.5 ±1.5 s": measured across vector units, as for distances); how it ended and the waypoints exactly.
WALK = re.compile(r"(?P<end>finished in|fell at|did not finish)(?: (?P<t>\d+\.\d)(?: ±(?P<tol>\d+\.\d))? s)?, "
                  r"waypoints (?P<k>\d+) of (?P<n>\d+)")


def replay_walk(argv: list[str], capsys) -> str:
    """How ``cpgjax follow ARGV`` (one controller, one path, one engine) ended, as a claim: "finished in 42.6 s,
    waypoints 32 of 32"."""
    capsys.readouterr()
    assert cli.main(["follow", *argv]) == 0
    out = capsys.readouterr().out
    rows = re.findall(r"^\S+ \S+(?: \[[^]]+\])?:\s+(finished in \d+\.\d s|fell at \d+\.\d s|did not finish), "
                      r"mean distance .*?(waypoints \d+ of \d+)", out, re.M)
    assert len(rows) == 1, f"cpgjax follow {' '.join(argv)}: one walk expected, it printed:\n{out}"
    return f"{rows[0][0]}, {rows[0][1]}"


def check_walk(claim: str, now: str, name: str, fix: str) -> None:
    """The walk claimed, ``claim``, and the one replayed, ``now``, ended the same way, at the same waypoint, at
    about the same time."""
    c, w = WALK.fullmatch(claim), WALK.fullmatch(now)
    assert c, f"{name}: the claim should read 'finished in T s|fell at T s|did not finish, waypoints K of N': {claim!r}"
    same = (c["end"], c["k"], c["n"]) == (w["end"], w["k"], w["n"])
    tol = None if c["t"] is None else RTOL * float(c["t"]) + 0.05 if c["tol"] is None else float(c["tol"])
    assert same and (c["t"] is None or abs(float(w["t"]) - float(c["t"])) <= tol), (
        f"{name}: the walk now {now}; the claim says {claim}: {fix}")
