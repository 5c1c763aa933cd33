"""The problem factory (cpgjax/optim/factory.py): the thesis's single episode and the robust evaluation."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from cpgjax.episode.batch import evaluate
from cpgjax.episode.perturb import Perturbations, draw
from cpgjax.io.ctl import read_ctl
from cpgjax.optim.algorithm import eval_keys
from cpgjax.optim.factory import make_problem

WL = "models/quadruped.wl"
P = Perturbations(replicas=3, roughness=0.003)


@pytest.fixture(scope="module")
def robust():
    p = make_problem(WL, time=0.3, evaluation="robust", perturb={"replicas": 3, "roughness": 0.003})
    return p, jax.jit(p.evaluate)


@pytest.fixture(scope="module")
def trot():
    return np.asarray(read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs, np.float32).reshape(-1)


def test_eval_keys_depend_on_the_run_the_generation_and_the_individual():
    k = jax.random.key(3)
    a, b = eval_keys(k, 0, 4), eval_keys(k, 1, 4)
    data = lambda keys: np.asarray(jax.random.key_data(keys)).reshape(len(keys), -1)  # noqa: E731
    assert len({tuple(r) for r in data(a)} | {tuple(r) for r in data(b)}) == 8      # all distinct
    np.testing.assert_array_equal(data(a), data(eval_keys(k, 0, 4)))                 # reproducible
    np.testing.assert_array_equal(data(a)[:2], data(eval_keys(k, 0, 2)))             # independent of N


def test_the_thesis_problem_is_deterministic_and_the_robust_one_is_stochastic(robust):
    thesis = make_problem(WL, time=0.3)
    assert not thesis.stochastic and thesis.meta["evaluation"] == "thesis"
    p, _ = robust
    assert p.stochastic and p.meta["evaluation"] == "robust" and p.meta["perturbations"]["replicas"] == 3
    assert "rough" in p.meta["terrain"]


@pytest.mark.slow  # 15 s; fast: experiments/test_robust.py
def test_robust_fitness_is_fresh_per_key_reproducible_and_batch_independent(robust, trot):
    _, f = robust
    G = jnp.asarray(np.repeat(trot[None], 4, 0))
    k0, k1 = eval_keys(jax.random.key(0), 0, 4), eval_keys(jax.random.key(0), 1, 4)
    r0 = np.asarray(f(G, k0)["fitness"])
    assert len(set(r0.tolist())) == 4                     # the same genome, 4 keys: 4 different episodes
    np.testing.assert_array_equal(r0, np.asarray(f(G, k0)["fitness"]))
    assert not np.any(np.asarray(f(G, k1)["fitness"]) == r0)       # the next generation: fresh draws
    # alone in a batch of one (the program the test below runs too): the same score
    np.testing.assert_array_equal(r0[1:2], np.asarray(f(G[1:2], k0[1:2])["fitness"]))


@pytest.mark.slow  # 7 s; fast: cli/test_replay.py averages jittered replicas
def test_robust_fitness_is_the_mean_of_its_replicas(robust, trot):
    """The replicas ride in the batch: the score is the mean of R single episodes with the drawn perturbations."""
    p, f = robust
    key = eval_keys(jax.random.key(1), 0, 1)
    got = float(f(jnp.asarray(trot[None]), key)["fitness"][0])
    from cpgjax.episode.perturb import roughened
    from cpgjax.io.wl import load_model

    m = load_model(WL)
    m = m.replace(terrain=roughened(m.terrain, P.roughness))
    ks = jax.random.split(key[0], P.replicas)
    var, off = draw(m, P, ks, m.n_genes)
    g = jnp.clip(jnp.asarray(trot)[None] + off, -0.8, 0.8).reshape(-1, m.n_ctrl, m.n_coeff)
    each = np.asarray(jax.jit(lambda g, v: evaluate(m, g, time=0.3, var=v, fall_ends=True))(g, var)["fitness"])
    assert len(set(each.tolist())) == P.replicas
    assert np.isclose(got, each.mean(), rtol=1e-3)     # another compiled program: last-bit rounding differs


def test_perturbation_ranges_are_checked():
    with pytest.raises(ValueError, match="friction"):
        Perturbations(friction=1.5)
    with pytest.raises(ValueError, match="replicas"):
        Perturbations(replicas=0)
    with pytest.raises(ValueError, match="needs a simulated model"):
        make_problem("analytic:sphere:10", evaluation="robust")
    with pytest.raises(ValueError, match="robust evaluation only"):
        make_problem(WL, perturb={"replicas": 2})


@pytest.mark.slow  # 15 s; fast: the robust scores' freshness and batch independence (this file)
def test_a_fall_forfeits_the_episode_with_fall_zero_and_scales_it_with_fall_survival(trot):
    """fall_zero: an episode whose body tilts past 60 degrees scores 0; fall_survival: its score times the share
    of the episode before the fall; the episodes without a fall score as with fall_ends alone."""
    keys = eval_keys(jax.random.key(5), 0, 8)
    G = jnp.asarray(np.repeat(trot[None], 8, 0))
    scores = {}
    for mode in ("ends", "fall_zero", "fall_survival"):   # started rolled or pitched by up to 80 degrees
        extra = {} if mode == "ends" else {mode: True}
        p = make_problem(WL, time=0.2, evaluation="robust", perturb={"replicas": 1, "tilt": 1.4} | extra)
        assert all(p.meta["perturbations"][k] is (k == mode) for k in ("fall_zero", "fall_survival"))
        scores[mode] = np.asarray(jax.jit(p.evaluate)(G, keys)["fitness"], float)
    fell = scores["fall_zero"] == 0
    assert 0 < fell.sum() < 8
    assert np.all(scores["ends"][fell] != 0)
    for mode in ("fall_zero", "fall_survival"):
        np.testing.assert_array_equal(scores[mode][~fell], scores["ends"][~fell])
    share = scores["fall_survival"][fell] / scores["ends"][fell]   # log samples still up, of the 4 in 0.2 s
    assert np.all((share >= 0) & (share < 1)) and np.allclose(share * 4, np.round(share * 4))
    with pytest.raises(ValueError, match="exclude each other"):
        Perturbations(fall_zero=True, fall_survival=True)


def test_turn_speed_lowers_the_credited_speed_as_the_episode_turns_harder():
    """``turn_speed``: the tracking fitness credits the speed up to ``speed`` on a straight episode, falling linearly to
    ``turn_speed`` on one commanded to turn at the full range; without it the cap is ``speed`` whatever the turn."""
    import jax.numpy as jnp

    from cpgjax.episode.perturb import Perturbations
    from cpgjax.optim.factory import episode_scores

    r = {"heading_fitness": jnp.ones(4), "turn_error": jnp.zeros(4)}
    turn = jnp.asarray([0.0, 0.2, 0.4, 0.3])
    p = Perturbations(command=0.4, speed=0.6, turn_speed=0.2)
    np.testing.assert_allclose(episode_scores(r, p, steered=True, turn=turn)["fitness"], [0.6, 0.4, 0.2, 0.3],
                               rtol=1e-6)
    flat = Perturbations(command=0.4, speed=0.6)
    np.testing.assert_allclose(episode_scores(r, flat, steered=True, turn=turn)["fitness"], 0.6, rtol=1e-6)
    assert "turn_speed" not in flat.to_dict()               # off: the run files made before it record as they did
    for bad in ({"command": 0.4, "turn_speed": 0.2}, {"command": 0.4, "speed": 0.1, "turn_speed": 0.2}):
        with pytest.raises(ValueError, match="turn_speed"):
            Perturbations(**bad)


def test_overspeed_charges_the_speed_past_the_cap_with_a_command_or_without():
    """``overspeed=K``: past the cap each m/s costs K m/s of the score (a gait 0.3 m/s too fast for its turn's cap of
    0.2 scores 0.2 - 0.3 K when it follows the command, -0.3 K when it ignores it), below it the speed is credited
    as it is; the same with eq. 4.6's fitness without a command; without ``speed`` it is refused, and off it is left
    out of the run file's record."""
    import jax.numpy as jnp

    from cpgjax.episode.perturb import Perturbations
    from cpgjax.optim.factory import episode_scores

    v = jnp.asarray([0.1, 0.5, 0.5, 0.3])
    r = {"heading_fitness": v, "turn_error": jnp.zeros(4)}
    turn = jnp.asarray([0.4, 0.4, 0.0, 0.2])                     # caps 0.2, 0.2, 0.6, 0.4
    p = Perturbations(command=0.4, speed=0.6, turn_speed=0.2, overspeed=1.0)
    np.testing.assert_allclose(episode_scores(r, p, steered=True, turn=turn)["fitness"], [0.1, -0.1, 0.5, 0.3],
                               rtol=1e-6, atol=1e-7)
    half = Perturbations(command=0.4, speed=0.6, turn_speed=0.2, overspeed=0.5)
    np.testing.assert_allclose(episode_scores(r, half, steered=True, turn=turn)["fitness"][1], 0.2 - 0.15, rtol=1e-6)
    # the charge comes after the turn error's factor: ignoring the command (an error of the whole range, factor 0)
    # does not escape it
    ignored = dict(r, turn_error=jnp.full(4, 0.4))
    np.testing.assert_allclose(episode_scores(ignored, p, steered=True, turn=turn)["fitness"], [0.0, -0.3, 0.0, 0.0],
                               atol=1e-7)
    plain = Perturbations(speed=0.4, overspeed=2.0)
    np.testing.assert_allclose(episode_scores({"fitness": v}, plain)["fitness"], [0.1, 0.2, 0.2, 0.3], rtol=1e-6)
    assert "overspeed" not in Perturbations(speed=0.4).to_dict() and plain.to_dict()["overspeed"] == 2.0
    for bad in ({"overspeed": 1.0}, {"speed": 0.4, "overspeed": -1.0}):
        with pytest.raises(ValueError, match="overspeed"):
            Perturbations(**bad)


def test_turn_tolerance_is_the_turn_error_at_which_the_steering_score_reaches_0():
    """``turn_tolerance=T``: the steering score falls linearly to 0 at a turn error of T times the command's range
    (0.5 by default, left out of the run file's record); a gait at 0.2 m/s that turns 0.2 rad/s short of a range
    of 0.4 scores 0 at the default and half its speed at T = 1; outside (0, 2], or without a command, refused."""
    import jax.numpy as jnp

    from cpgjax.episode.perturb import Perturbations
    from cpgjax.optim.factory import episode_scores

    r = {"heading_fitness": jnp.full(3, 0.2), "turn_error": jnp.asarray([0.0, 0.2, 0.4])}
    default = Perturbations(command=0.4)
    np.testing.assert_allclose(episode_scores(r, default, steered=True)["fitness"], [0.2, 0.0, 0.0], atol=1e-7)
    wide = Perturbations(command=0.4, turn_tolerance=1.0)
    np.testing.assert_allclose(episode_scores(r, wide, steered=True)["fitness"], [0.2, 0.1, 0.0], atol=1e-7)
    assert "turn_tolerance" not in default.to_dict() and wide.to_dict()["turn_tolerance"] == 1.0
    for bad in ({"command": 0.4, "turn_tolerance": 0.0}, {"command": 0.4, "turn_tolerance": 3.0},
                {"turn_tolerance": 1.0}):
        with pytest.raises(ValueError, match="turn_tolerance"):
            Perturbations(**bad)


def test_per_cap_scores_each_steering_episode_as_a_share_of_its_cap():
    """``per_cap=on``: the steering score over the episode's speed cap, so that a turn at its cap scores 1 as a
    straight walk at the full cap does (0.2 m/s in a full turn capped at 0.2, 0.6 m/s straight capped at 0.6, 0.3 m/s
    in a half turn capped at 0.4: 1, 1, 0.75); refused without a command or a speed cap."""
    import jax.numpy as jnp

    from cpgjax.episode.perturb import Perturbations
    from cpgjax.optim.factory import episode_scores

    r = {"heading_fitness": jnp.asarray([0.2, 0.6, 0.3]), "turn_error": jnp.zeros(3)}
    turn = jnp.asarray([0.4, 0.0, 0.2])
    p = Perturbations(command=0.4, speed=0.6, turn_speed=0.2, per_cap=True)
    np.testing.assert_allclose(episode_scores(r, p, steered=True, turn=turn)["fitness"], [1.0, 1.0, 0.75], rtol=1e-6)
    assert "per_cap" not in Perturbations(command=0.4).to_dict() and p.to_dict()["per_cap"] is True
    for bad in ({"command": 0.4, "per_cap": True}, {"speed": 0.5, "per_cap": True}):
        with pytest.raises(ValueError, match="per_cap"):
            Perturbations(**bad)


def test_worst_scores_a_controller_by_the_mean_of_its_worst_episodes():
    """``worst=K``: the fitness is the mean of the K lowest of a controller's episodes; the other metrics stay the
    means of all of them; 0 (the default, left out of the run file's record) is the mean of all."""
    from cpgjax.optim.factory import METRICS, replica_scores

    fit = jnp.asarray([0.4, 0.1, 0.3, 0.2, 0.5, 0.5, -0.1, 0.9])     # two controllers of four episodes each
    r = {k: jnp.zeros(8) for k in METRICS} | {"fitness": fit, "diverged": jnp.zeros(8, bool),
                                               "speed": jnp.arange(8.0)}
    got = {w: replica_scores(r, Perturbations(replicas=4, worst=w), 2) for w in (0, 1, 2, 4)}
    np.testing.assert_allclose(got[0]["fitness"], [0.25, 0.45], rtol=1e-6)
    np.testing.assert_allclose(got[1]["fitness"], [0.1, -0.1], rtol=1e-6)
    np.testing.assert_allclose(got[2]["fitness"], [0.15, 0.2], rtol=1e-6)
    np.testing.assert_allclose(got[4]["fitness"], got[0]["fitness"], rtol=1e-6)
    for w in (1, 2):
        np.testing.assert_array_equal(got[w]["speed"], [1.5, 5.5])
    assert "worst" not in Perturbations().to_dict() and Perturbations(worst=2).to_dict()["worst"] == 2
    with pytest.raises(ValueError, match="worst"):
        Perturbations(replicas=4, worst=5)


def test_free_holds_every_gene_but_the_named_groups_at_the_starts():
    """``--free command+steer+turn`` on the mirrored steering family started from the rough walker: the 22 genes
    that weigh the command (4), the command times the phase (12) and its size (6) evolve, the CPG and the weights
    of tilt, contact and bias are held at the walker's; the groups are checked and recorded."""
    from cpgjax.episode.policy import parse_controller
    from cpgjax.io.wl import load_model
    from cpgjax.optim.algorithm import make_algorithm
    from cpgjax.optim.baselines import SearchConfig

    fam = "pmtg:tilt+contact+command+steer+turn+bias:mirror"
    p = make_problem(WL, pipeline="exact", start="models/quadruped-rough.ctl", controller=fam,
                     evaluation="robust", perturb={"command": 0.4}, free="turn+steer+command", time=0.3)
    labels = parse_controller(fam).gene_groups(load_model(WL, pipeline="exact"))
    assert p.meta["free"] == "command+steer+turn" and len(labels) == p.n_genes == 78
    np.testing.assert_array_equal(~p.held, np.isin(labels, ["command", "steer", "turn"]))
    assert (~p.held).sum() == 22 and set(labels[p.held]) == {"cpg", "tilt", "contact", "bias"}
    with pytest.raises(ValueError, match="distinct ones of cpg, tilt, contact, command, steer, turn, bias"):
        make_problem(WL, controller=fam, free="steer+rates", time=0.3)
    with pytest.raises(ValueError, match="every gene evolves"):
        make_problem(WL, free="cpg", time=0.3)
    with pytest.raises(ValueError, match="applies to the GA"):
        make_algorithm(p, SearchConfig(method="amc"))
