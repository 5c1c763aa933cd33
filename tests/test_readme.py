"""The README's examples are what the commands print now.

An example in README.md is a command and its output, marked for this test::

    <!-- example -->
    ```
    $ cpgjax simulate models/quadruped.wl --ctl models/quadruped-trot.ctl
    ...the output, exactly...
    ```

The test runs each command (in process) and compares.  ``make readme`` (``UPDATE_README=1``)
rewrites the outputs in place from a fresh run instead.
"""

from __future__ import annotations

import os
import re
import shlex
from pathlib import Path

import pytest

from cpgjax import cli

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCK = re.compile(r"(<!-- example -->\n```\n\$ (?P<cmd>cpgjax [^\n]+)\n)(?P<out>.*?)(```)", re.S)


def examples() -> list[tuple[str, str]]:
    return [(m["cmd"], m["out"]) for m in BLOCK.finditer(README.read_text())]


def run(cmd: str, capsys) -> str:
    capsys.readouterr()
    code = cli.main(shlex.split(cmd)[1:])
    out = capsys.readouterr().out
    assert code == 0, f"{cmd} exited {code}"
    return out


def test_the_readme_has_examples():
    assert len(examples()) >= 1


@pytest.mark.parametrize("cmd,expected", examples(), ids=[c for c, _ in examples()])
def test_readme_example_prints_what_the_readme_says(cmd, expected, capsys):
    got = run(cmd, capsys)
    if os.environ.get("UPDATE_README"):
        text = README.read_text()
        text = BLOCK.sub(lambda m: m.group(1) + (got if m["cmd"] == cmd else m["out"]) + m.group(4), text)
        README.write_text(text)
        return
    assert got == expected, f"README.md's example of `{cmd}` is stale; run `make readme` (UPDATE_README=1)"
