"""Fuzzing the `.wl` and `.ctl` readers: any input is a model or one DescriptionError, never a crash.

Seeded random mutations of the shipped models (``models/*.wl``, ``models/*.ctl``): deleted,
duplicated and swapped lines, deleted, duplicated and swapped tokens, tokens replaced by
keywords, names or odd numbers (``nan``, ``1e309``, ``-0``, ``1e-300``, ...), truncation
and random bytes.  A `.wl` that the parser accepts must also build
(:func:`cpgjax.sim.model.build_model`) and survive ``format_wl`` -> ``parse_wl``.

The fast suite runs ~200 cases; ``-m slow`` a few thousand.  A failure names the seed
and the mutated text, so it can be replayed with :func:`mutate`.
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from cpgjax.errors import DescriptionError
from cpgjax.io.ctl import read_ctl
from cpgjax.io.wl import format_wl, load_wl, parse_wl
from cpgjax.io.wl.lexer import ALL_KEYWORDS
from cpgjax.sim.model import build_model

MODELS = Path(__file__).resolve().parents[2] / "models"
WL = {p.name: p.read_bytes() for p in sorted(MODELS.glob("*.wl"))}
CTL = {p.name: p.read_bytes() for p in sorted(MODELS.glob("*.ctl"))}
# the controlled DOFs and harmonics of each controller's model, to read it as the CLI does
CTL_SHAPE = {"hexapod.ctl": (12, 2), "quadruped-robust.ctl": (8, 2),
             "quadruped-trot.ctl": (8, 2), "quadruped-steer.ctl": (8, 2), "quadruped-rough.ctl": (8, 2),
             "quadruped-walker.ctl": (8, 2),
             "worm.ctl": (4, 2)}

ODD_NUMBERS = ["nan", "-nan", "inf", "-inf", "1e309", "-1e309", "1e999", "-0", "0", "-0.0", "+0", "1e300",
               "-1e300", "1e-300", "5e-324", "-1", "1", "2", "3", "1e6", "1e-6", "2.5", "-2.5", "1.5707963",
               "99999999999", "12345678901234567890", ".", "-", "+", "1e", "0x10", "1_0", "١", "½"]
ODD_TOKENS = ["{", "}", "#", "X", "Y", "ON", "OFF", "Cube", "Cylinder", "Sphere", "flat", "ramp", "bump",
              "rough", "matrix", "\u00a0", "\ufeff", "\u2028", "é", "\t"]
KEYWORDS = sorted(ALL_KEYWORDS)


def _tokens(line: str) -> list[str]:
    return line.split()


def _is_float(tok: str) -> bool:
    try:
        float(tok)
    except ValueError:
        return False
    return True


def mutate(data: bytes, seed: int) -> bytes:
    """1 to 3 random edits of ``data`` (the same ``seed`` gives the same result)."""
    rng = random.Random(seed)
    text = data.decode("utf-8")
    names = sorted({t for line in text.splitlines() for t in _tokens(line) if t[:1].isalpha()})
    for _ in range(rng.randint(1, 3)):
        lines = text.split("\n")
        op = rng.randrange(12)
        i = rng.randrange(len(lines))
        toks = _tokens(lines[i])
        if op == 0:  # delete a line
            del lines[i]
        elif op == 1:  # duplicate a line
            lines.insert(rng.randrange(len(lines) + 1), lines[i])
        elif op == 2:  # swap two lines
            k = rng.randrange(len(lines))
            lines[i], lines[k] = lines[k], lines[i]
        elif op in (3, 4, 5, 6, 7) and toks:
            t = rng.randrange(len(toks))
            if op == 3:  # replace a token by an odd number
                toks[t] = rng.choice(ODD_NUMBERS)
            elif op == 4:  # replace a token by a keyword, a name of the file or an odd token
                toks[t] = rng.choice([rng.choice(KEYWORDS), rng.choice(names or ["A"]), rng.choice(ODD_TOKENS)])
            elif op == 5:  # delete a token
                del toks[t]
            elif op == 6:  # duplicate a token
                toks.insert(rng.randrange(len(toks) + 1), toks[t])
            else:  # swap two tokens, or move one to another line
                k = rng.randrange(len(toks))
                toks[t], toks[k] = toks[k], toks[t]
            lines[i] = "    " + " ".join(toks)
        elif op == 8:  # a token from another line, inserted here
            other = _tokens(rng.choice(lines)) or ["}"]
            lines[i] = lines[i] + " " + rng.choice(other)
        elif op == 9:  # truncate (also in the middle of a token)
            text = text[: rng.randrange(len(text) + 1)]
            continue
        elif op == 10:  # random bytes somewhere (may not be UTF-8)
            raw = text.encode("utf-8")
            at = rng.randrange(len(raw) + 1)
            junk = bytes(rng.randrange(256) for _ in range(rng.randint(1, 8)))
            return raw[:at] + junk + raw[at:]
        else:  # scale a number
            nums = [t for t, tok in enumerate(toks) if _is_float(tok)]
            if nums:
                t = rng.choice(nums)
                toks[t] = repr(float(toks[t]) * rng.choice([-1.0, 0.0, 1e-9, 1e9, 1e200, 3.0]))
                lines[i] = "    " + " ".join(toks)
        text = "\n".join(lines)
    return text.encode("utf-8")


def _check_wl(tmp_path: Path, name: str, seed: int) -> str:
    data = mutate(WL[name], seed)
    path = tmp_path / name
    path.write_bytes(data)
    try:
        desc = load_wl(path)
        build_model(desc)
        again = parse_wl(format_wl(desc), "again.wl")
        build_model(again)
    except DescriptionError as e:
        msg = str(e)
        assert msg.startswith(f"{path}:"), msg
        assert "\n" not in msg, msg
        return "rejected"
    except Exception as e:  # noqa: BLE001 - the point: nothing else may escape
        text = data.decode("utf-8", "replace")
        pytest.fail(f"{name} seed {seed}: {type(e).__name__}: {e}\n--- mutated file ---\n{text}")
    return "accepted"


def _check_ctl(tmp_path: Path, name: str, seed: int) -> str:
    data = mutate(CTL[name], seed)
    path = tmp_path / name
    path.write_bytes(data)
    outcome = []
    for shape in ((None, None), CTL_SHAPE[name]):
        try:
            read_ctl(path, *shape)
            outcome.append("accepted")
        except DescriptionError as e:
            msg = str(e)
            assert msg.startswith(f"{path}:"), msg
            assert "\n" not in msg, msg
            outcome.append("rejected")
        except Exception as e:  # noqa: BLE001
            text = data.decode("utf-8", "replace")
            pytest.fail(f"{name} seed {seed} {shape}: {type(e).__name__}: {e}\n--- mutated file ---\n{text}")
    return outcome[-1]


def _run(tmp_path: Path, n_wl: int, n_ctl: int, base: int) -> dict[str, int]:
    counts = {"accepted": 0, "rejected": 0}
    for k in range(n_wl):
        name = list(WL)[k % len(WL)]
        counts[_check_wl(tmp_path, name, base + k)] += 1
    for k in range(n_ctl):
        name = list(CTL)[k % len(CTL)]
        counts[_check_ctl(tmp_path, name, base + k)] += 1
    return counts


def test_shipped_models_are_the_fuzzers_seeds():
    assert set(CTL) == set(CTL_SHAPE) and len(WL) >= 4
    for name, data in WL.items():
        build_model(parse_wl(data.decode("utf-8"), name))
    for name, (n_dof, k) in CTL_SHAPE.items():
        read_ctl(MODELS / name, n_dof, k)


def test_mutations_are_reproducible_and_varied():
    data = WL["quadruped.wl"]
    assert mutate(data, 7) == mutate(data, 7)
    assert len({mutate(data, s) for s in range(50)}) >= 45


def test_fuzz_fast(tmp_path):
    counts = _run(tmp_path, n_wl=120, n_ctl=80, base=0)
    assert counts["rejected"] > 50 and counts["accepted"] > 10, counts  # both paths are exercised


@pytest.mark.slow
def test_fuzz_slow(tmp_path):
    counts = _run(tmp_path, n_wl=3000, n_ctl=1500, base=100_000)
    print(counts)
    assert counts["rejected"] > 1000 and counts["accepted"] > 100, counts
