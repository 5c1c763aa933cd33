"""Every option of every command explains itself in words (issue 51, "The front door").

The parsers are built and walked, nothing is run: an option without help, or whose help is only a symbol and an
equation, chapter or figure number ("gamma of eq. 6.1"), fails; so does a ``--perturb`` help that leaves out a key
of :class:`~cpgjax.episode.perturb.Perturbations` or a preset.
"""

from __future__ import annotations

import argparse
import dataclasses
import re

import pytest

from cpgjax.cli import build_parser

# references to the thesis, and the default, which do not explain what an option does
_REFERENCE = re.compile(r"\b(?:eqs?|Ch|Figs?|Table)\.? ?[A-Z]?[\d.]+(?:\s*[-/–]\s*[\d.]+)?", re.IGNORECASE)
_DEFAULT = re.compile(r"\((?:default|thesis)[^)]*\)|\bdefault\b[^;,)]*", re.IGNORECASE)
_FILLER = {"of", "the", "a", "an", "and", "or", "in", "on", "to", "by", "see", "for", "with", "is", "its", "it"}
MIN_WORDS = 3


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


COMMANDS = _commands()


def _explains(text: str | None) -> bool:
    """Whether ``text`` says in words what an option does: some words left once the references and the default
    are taken out."""
    if not text or text == argparse.SUPPRESS:
        return False
    rest = _DEFAULT.sub(" ", _REFERENCE.sub(" ", text))
    words = [w for w in re.findall(r"[A-Za-z][\w'-]+", rest) if w.lower() not in _FILLER]
    return len(words) >= MIN_WORDS


@pytest.mark.parametrize("text,ok", [
    ("gamma of eq. 6.1 (default 0.0)", False), ("mu_max of eq. 6.1", False), ("N (default 20)", False),
    ("eq. 4.5", False), ("", False), (None, False), ("generations (default 150)", False),
    ("delta of S(θ), eq. 6.2 (default 8)", False),
    ("how fast the mutation rate decays (eq. 6.1; default 0)", True),
    ("keep only the best P controllers as parents (default 0)", True),
])
def test_the_rule_itself(text, ok):
    assert _explains(text) is ok


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_option_is_explained_in_words(command):
    p = COMMANDS[command]
    bad = [f"{'/'.join(a.option_strings) or a.dest}: {a.help!r}" for a in p._actions
           if not isinstance(a, (argparse._HelpAction, argparse._VersionAction)) and not _explains(a.help)]
    assert not bad, f"cpgjax {command}: options without help in words: {bad}"
    assert p.description and _explains(p.description), f"cpgjax {command}: no description"
    p.format_help()          # a stray % in a help string raises here


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_an_option_with_a_set_default_says_it(command):
    """A default set in the parser (not left to a run's or a model file's settings) is in the help."""
    bad = [a.dest for a in COMMANDS[command]._actions
           if not isinstance(a, (argparse._HelpAction, argparse._VersionAction, argparse._StoreTrueAction))
           and a.default not in (None, False, [], argparse.SUPPRESS) and "default" not in (a.help or "").lower()
           and not a.required and a.option_strings]
    assert not bad, f"cpgjax {command}: options that do not say their default: {bad}"


def _option(command: str, name: str) -> argparse.Action:
    return next(a for a in COMMANDS[command]._actions if name in a.option_strings)


@pytest.mark.parametrize("command", [c for c in sorted(COMMANDS)
                                     if any("--perturb" in a.option_strings for a in COMMANDS[c]._actions)])
def test_perturb_help_names_every_key_and_preset(command):
    from cpgjax.episode.perturb import MEANING, PRESETS, Perturbations

    fields = [f.name for f in dataclasses.fields(Perturbations)]
    assert set(MEANING) == set(fields)
    text = _option(command, "--perturb").help
    missing = [f for f in fields if not re.search(rf"\b{f}=", text)]
    assert not missing, f"cpgjax {command} --perturb: keys not explained: {missing}"
    for name, values in PRESETS.items():
        assert f"preset={name}" in text
        assert all(re.search(rf"\b{k}=", text) for k in values)


def test_the_words_a_newcomer_asked_for():
    ev = COMMANDS["evolve"]
    assert "best P" in _option("evolve", "--pocket").help
    assert "decays" in _option("evolve", "--gamma").help
    assert "policies modulating trajectory generators" in _option("evolve", "--controller").help
    assert "bristle=" in _option("evolve", "--perturb").help
    assert "domain randomisation" in _option("evolve", "--perturb").help
    assert ev.description
    top = build_parser().format_help()
    for what in ("closed-loop", "MAP-Elites", "MuJoCo", "damaged", "steering"):
        assert what in top, what


def test_cpgjax_help_imports_no_command_and_no_jax_and_lists_what_the_full_parser_lists(monkeypatch):
    """``cpgjax --help`` builds only the names and lines of :data:`cpgjax.cli.COMMANDS` (JAX's import took 2-3 s
    here): the same text as the parser of every command, and a command's own parser is the same when built alone."""
    import os
    import subprocess
    import sys

    from cpgjax.cli import COMMANDS as TABLE

    monkeypatch.setenv("COLUMNS", "100")      # argparse's width, here and in the child, whatever the terminal

    code = ("import sys; from cpgjax.cli import main; rc = main(['--help']); "
            "print('JAX IMPORTED' if 'jax' in sys.modules else 'no jax', rc)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env=os.environ).stdout
    assert out.endswith("no jax 0\n")
    assert out[:-len("no jax 0\n")] == build_parser().format_help()
    assert set(COMMANDS) == set(TABLE)
    for name in TABLE:
        alone = next(a for a in build_parser([name, "--help"])._actions if isinstance(a, argparse._SubParsersAction))
        assert alone.choices[name].format_help() == COMMANDS[name].format_help()
