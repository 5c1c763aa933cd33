"""A run's champion chosen by validation (cpgjax/experiments/validate.py): the run's best distinct candidates
re-scored over common perturbed episodes, deterministic given the seed; `best --validate`, `transfer --pick`."""

from __future__ import annotations

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from runcases import TINY_TIME

from cpgjax import cli
from cpgjax.experiments import validate as V
from cpgjax.io.ctl import read_ctl
from cpgjax.io.results import read_run

SMALL = V.Validation(candidates=4, episodes=2)        # one compiled scorer for the whole file


@pytest.fixture(scope="module")
def runs(tiny_runs):
    """The folder of the suite's tiny thesis and robust runs (tests/runcases.py: 6 robots, 2 generations, 0.3 s;
    the robust one with replicas 2, fall_survival on, bristle 3)."""
    tiny_runs["thesis"], tiny_runs["robust"]
    return tiny_runs.folder


def test_candidates_are_the_runs_best_distinct_genomes_best_first(runs):
    run = read_run(runs / "robust.h5")
    where, genomes, recorded = V.candidates(run, 5)
    assert len(genomes) == 5 and len({g.tobytes() for g in genomes}) == 5
    gen, idx, fit, genome = run.best()
    assert (where[0] == (gen, idx)).all() and recorded[0] == fit and (genomes[0] == genome).all()
    assert np.all(np.diff(recorded) <= 0)
    for (g, i), gen_, r in zip(where, genomes, recorded, strict=True):
        assert (run.genomes[g, i] == gen_).all() and run.valid_fitness()[g, i] == r
    # asking for more than the run holds gives every distinct one
    distinct = {g.tobytes() for g in run.genomes.reshape(-1, run.genomes.shape[-1])}
    assert len(V.candidates(run, 10_000)[1]) == len(distinct)


def test_the_validation_episodes_are_the_runs_own_or_the_recommended_ones(runs):
    robust = V.perturbations(read_run(runs / "robust.h5"), 7)
    assert robust.replicas == 7 and robust.fall_survival and robust.bristle == 3.0
    thesis = V.perturbations(read_run(runs / "thesis.h5"), 5)
    assert thesis.replicas == 5 and thesis.fall_survival == V.THESIS_RUNS["fall_survival"]
    assert thesis.bristle == V.THESIS_RUNS["bristle"]
    with pytest.raises(ValueError, match="episodes must be >= 1"):
        V.Validation(episodes=0)
    # a run scored by its worst episodes (--perturb worst=K) is validated by the mean, whatever its K
    run = read_run(runs / "robust.h5")
    run.meta["perturbations"] = dict(run.meta["perturbations"], replicas=4, worst=4)
    assert V.perturbations(run, 2).worst == 0
    assert V.perturbations(run, 8, (("worst", 2),)).worst == 2       # unless the validation asks for it


def test_stricter_validation_ranges_replace_the_runs_own(runs):
    """``--validate-perturb``: the validation episodes take the given ranges in place of the run's (a stricter
    test than the evolution's), the rest stay the run's."""
    run = read_run(runs / "robust.h5")
    own = V.perturbations(run, 7)
    strict = V.perturbations(run, 7, (("fall_survival", False), ("fall_zero", True), ("jitter", 0.003)))
    assert strict.fall_zero and not strict.fall_survival and strict.jitter == 0.003 and own.jitter != 0.003
    assert (strict.bristle, strict.replicas) == (own.bristle, 7)
    assert V.perturbations(run, 7, (("preset", "domain"),)).roughness == 0.04
    assert V.Validation(perturb=(("fall_zero", True), ("jitter", 0.003))).stricter == ", fall_zero=True, jitter=0.003"
    assert V.Validation().stricter == ""
    # the ranges reach the validation's episodes: a range the run's controller cannot feel is refused there
    with pytest.raises(ValueError, match="touch"):
        V.validate(run, V.Validation(candidates=4, episodes=2, perturb=(("touch", 0.001),)))


def test_the_champion_is_the_best_mean_over_common_episodes_and_reproducible(runs):
    run = read_run(runs / "robust.h5")
    ch = V.validate(run, SMALL)
    assert len(ch.scores) == SMALL.candidates and ch.score == np.nanmax(ch.scores)
    assert (run.genomes[ch.generation, ch.index] == ch.genome).all()
    assert ch.recorded == run.valid_fitness()[ch.generation, ch.index]
    again = V.validate(run, SMALL)
    np.testing.assert_array_equal(again.scores, ch.scores)                  # deterministic given the seed
    other = V.validate(run, V.Validation(candidates=4, episodes=2, seed=1))
    assert not np.array_equal(other.scores, ch.scores)                      # another seed, other episodes
    # common random numbers: every candidate meets the same episodes, so one genome in every slot scores the same
    _, genomes, _ = V.candidates(run, SMALL.candidates)
    score = V._scorer(str(run.meta["model_text"]), str(run.meta["model_path"]), None, TINY_TIME, 8.0,
                      V.perturbations(run, SMALL.episodes))
    key = jax.random.fold_in(jax.random.key(SMALL.seed), V.VALIDATION_STREAM)
    same = np.repeat(genomes[:1], SMALL.candidates, axis=0)
    s = np.asarray(score(jnp.asarray(same), jnp.repeat(key[None], SMALL.candidates, axis=0))["fitness"])
    assert np.all(s == ch.scores[0])
    # the episode's length is data: a shorter validation scores otherwise through the same compiled program
    traced = []

    def listen(event, _, **kw):        # a new program is traced (whether or not the disk cache then serves it)
        if "jaxpr_trace" in event:
            traced.append(event)

    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        half = V._scorer(str(run.meta["model_text"]), str(run.meta["model_path"]), None, TINY_TIME / 2, 8.0,
                         V.perturbations(run, SMALL.episodes))
        h = np.asarray(half(jnp.asarray(same), jnp.repeat(key[None], SMALL.candidates, axis=0))["fitness"])
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)
    assert not np.array_equal(h, s) and traced == []


def test_best_validate_writes_the_champion_as_a_ctl(runs, tmp_path, capsys):
    out = tmp_path / "champion.ctl"
    argv = ["best", str(runs / "thesis.h5"), "--validate", "--candidates", "4", "--episodes", "2", "--ctl", str(out)]
    assert cli.main(argv) == 0
    text = capsys.readouterr().out
    assert "validated 4 candidates over 2 perturbed episodes" in text and "champion fitness" in text
    ch = V.validate(read_run(runs / "thesis.h5"), SMALL)
    coeffs = read_ctl(str(out)).coeffs
    np.testing.assert_array_equal(np.asarray(coeffs, np.float32).ravel(), ch.genome)
    assert cli.main(["best", str(runs / "thesis.h5"), "--validate", "--episodes", "0"]) == 2
    assert "--episodes" in capsys.readouterr().err
    assert cli.main(["best", str(runs / "thesis.h5"), "--validate", "--validate-perturb", "bogus=1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--validate-perturb" in err[0] and "bogus=1" in err[0]


@pytest.mark.slow  # fast: cpgjax transfer end to end (crosscheck/test_transfer.py)
def test_transfer_replays_the_validated_champion(runs, capsys):
    argv = ["transfer", str(runs / "robust.h5"), "--replays", "1", "--pick", "validated", "--candidates", "4",
            "--episodes", "2", "--json"]
    assert cli.main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["pick"] == "validated" and summary["runs"] == 1
    from cpgjax.crosscheck import transfer

    ch = V.validate(read_run(runs / "robust.h5"), SMALL)
    (r,) = transfer.replay_runs([runs / "robust.h5"], replays=1, pick=lambda run: (ch.recorded, ch.genome,
                                                                                      ch.to_dict()))
    assert r.fitness_in_run == ch.recorded and r.pick["score"] == ch.score and r.pick["candidates"] == 4
