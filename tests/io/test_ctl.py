"""The `.ctl` control file (thesis Ch. 3.5.1)."""

from __future__ import annotations

import numpy as np
import pytest

from cpgjax.io.ctl import (
    Control,
    coeffs_to_genome,
    format_ctl,
    genome_to_coeffs,
    parse_ctl,
    read_ctl,
    write_ctl,
)
from cpgjax.sim.description import DescriptionError

# The thesis example (Ch. 3.5.1): fitness, then 8 DOFs x (c0 a1 b1 a2 b2).
THESIS_CTL = """\
0.012402
0.400000  0.255476  0.032754  -0.030112  0.013921
0.034243  0.039600  0.014926  -0.007822  0.000000
0.000000  0.364647  -0.319100  0.000000  0.000000
0.000000  0.000000  0.000000  0.030025  0.032101
0.000000  0.004799  -0.372179  -0.332543  0.000000
-0.044946  0.003917  0.000000  0.000000  -0.011471
0.000000  0.039063  0.000000  -0.442531  0.300000
0.037914  0.005913  -0.029453  0.012439  0.000000
"""


def _write(tmp_path, text: str, name: str = "c.ctl") -> str:
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def test_thesis_example(tmp_path):
    path = _write(tmp_path, THESIS_CTL)
    c = read_ctl(path, n_dof=8, harmonics=2)
    assert isinstance(c, Control) and c.path == path
    assert c.fitness == 0.012402
    assert c.coeffs.shape == (8, 5) and c.coeffs.dtype == np.float64
    assert c.coeffs[0].tolist() == [0.4, 0.255476, 0.032754, -0.030112, 0.013921]
    assert c.coeffs[6, 3] == -0.442531
    assert (c.n_dof, c.harmonics) == (8, 2)
    assert c.genome.shape == (40,) and c.genome[5] == 0.034243


def test_counts_are_inferred_when_not_given():
    c = parse_ctl("1.5\n0 1 2\n3 4 5\n")
    assert (c.fitness, c.n_dof, c.harmonics, c.path) == (1.5, 2, 1, "<string>")


def test_blank_lines_and_comments_are_tolerated(tmp_path):
    text = "# best of generation 12\n\n0.5   # fitness\n\n1 2 3  # hip\n# knee next\n4 5 6\n"
    c = read_ctl(_write(tmp_path, text), n_dof=2, harmonics=1)
    assert c.fitness == 0.5 and c.coeffs.tolist() == [[1, 2, 3], [4, 5, 6]]


def test_write_read_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    coeffs = rng.uniform(-0.8, 0.8, size=(8, 5))
    coeffs[2, 1] = -1e-9  # rounds to zero: written without a minus sign
    path = tmp_path / "rt.ctl"
    write_ctl(path, coeffs, fitness=0.0964)
    text = path.read_text()
    lines = text.splitlines()
    assert lines[0] == "0.096400" and len(lines) == 9
    assert all(len(ln.split("  ")) == 5 for ln in lines[1:])
    assert "-0.000000" not in text
    c = read_ctl(path, n_dof=8, harmonics=2)
    np.testing.assert_allclose(c.coeffs, coeffs, atol=5e-7)
    assert c.fitness == 0.0964
    # a second round trip is exact
    assert format_ctl(c.coeffs, c.fitness) == text


def test_thesis_text_round_trips_exactly():
    c = parse_ctl(THESIS_CTL)
    assert format_ctl(c.coeffs, c.fitness) == THESIS_CTL


def test_genome_coeffs_row_major():
    coeffs = np.arange(10.0).reshape(2, 5)
    g = coeffs_to_genome(coeffs)
    assert g.tolist() == list(range(10))
    np.testing.assert_array_equal(genome_to_coeffs(g, 2, 2), coeffs)
    batch = np.arange(30.0).reshape(3, 10)  # a population of genomes
    assert genome_to_coeffs(batch, 2, 2).shape == (3, 2, 5)
    np.testing.assert_array_equal(coeffs_to_genome(genome_to_coeffs(batch, 2, 2)), batch)
    assert genome_to_coeffs(list(range(5)), 1, 2).shape == (1, 5)
    with pytest.raises(ValueError, match=r"genome has 10 genes, expected n_dof \* \(2K\+1\) = 2 \* 7 = 14"):
        genome_to_coeffs(g, 2, 3)
    with pytest.raises(ValueError, match="coeffs must be"):
        coeffs_to_genome(np.zeros(3))


def test_format_rejects_bad_input():
    with pytest.raises(ValueError, match="coeffs must be"):
        format_ctl(np.zeros((2, 4)))
    with pytest.raises(ValueError, match="coeffs must be"):
        format_ctl(np.zeros(5))
    with pytest.raises(ValueError, match="finite"):
        format_ctl(np.zeros((1, 3)), fitness=float("nan"))


BAD_CTL = [
    # (id, text, n_dof, harmonics, line, message)
    ("too-few-dofs", THESIS_CTL.replace("0.037914  0.005913  -0.029453  0.012439  0.000000\n", ""), 8, 2, 8,
     "expected 8 DOF lines of 5 coefficients (K=2), found 7 DOF lines"),
    ("too-many-dofs", THESIS_CTL, 7, 2, 9, "expected 7 DOF lines of 5 coefficients (K=2), found 8 DOF lines"),
    ("wrong-harmonics", THESIS_CTL, 8, 3, 2,
     "expected 8 DOF lines of 7 coefficients (K=3), found a line of 5 numbers"),
    ("short-line", THESIS_CTL.replace("0.034243  0.039600  0.014926  -0.007822  0.000000",
                                      "0.034243  0.039600  0.014926  -0.007822"), None, None, 3,
     "expected DOF lines of 5 coefficients (K=2), found a line of 4 numbers"),
    ("bad-token", THESIS_CTL.replace("0.364647", "x"), None, None, 4, "'x' is not a number"),
    ("comma", "0.1\n0.1, 0.2, 0.3\n", None, None, 2, "'0.1,' is not a number"),
    ("nan", "0.1\n0 nan 0\n", None, None, 2, "'nan' is not a finite number"),
    ("bad-fitness", "good\n0 0 0\n", None, None, 1, "'good' is not a number"),
    ("missing-fitness", THESIS_CTL.split("\n", 1)[1], 8, 2, 1,
     "the first line must be the fitness (one number), found 5 numbers"),
    ("empty", "", None, None, 1, "empty control file: expected the fitness on the first line"),
    ("only-comments", "# nothing\n\n", 2, 1, 1,
     "empty control file: expected the fitness on the first line, then 2 DOF lines of 3 coefficients (K=1)"),
    ("fitness-only", "0.5\n\n", 8, 2, 1,
     "expected 8 DOF lines of 5 coefficients (K=2) after the fitness, found none"),
    ("even-count", "0.5\n1 2 3 4\n", None, None, 2, "a DOF line has 2K+1 numbers"),
]


@pytest.mark.parametrize(("text", "n_dof", "harmonics", "line", "message"), [b[1:] for b in BAD_CTL],
                         ids=[b[0] for b in BAD_CTL])
def test_malformed_ctl(tmp_path, text, n_dof, harmonics, line, message):
    path = _write(tmp_path, text, "bad.ctl")
    with pytest.raises(DescriptionError) as e:
        read_ctl(path, n_dof=n_dof, harmonics=harmonics)
    assert str(e.value).startswith(f"{path}:{line}: "), str(e.value)
    assert message in e.value.message, e.value.message


def _closed_loop(model):
    from cpgjax.episode import policy as pol

    fam = pol.Family()
    g = np.random.default_rng(4).uniform(-0.8, 0.8, (1, fam.n_genes(model))).astype(np.float32)
    return pol.from_genomes(fam, model, g)[0]


def test_a_closed_loop_controller_round_trips_through_its_ctl_file(tmp_path):
    """The CPG's coefficients and the policy's weights read back as the same float32 (exact digits)."""
    from cpgjax.episode import policy as pol
    from cpgjax.io.ctl import PolicyTable
    from cpgjax.io.wl import load_model

    m = load_model("models/quadruped.wl")
    c = _closed_loop(m)
    path = str(tmp_path / "cl.ctl")
    write_ctl(path, c.coeffs, 0.5, exact=True, policy=PolicyTable(**pol.table_fields(c, m)))
    back = read_ctl(path, n_dof=8, harmonics=2)
    assert back.policy.inputs[3] == ("contact", 4) and back.policy.outputs == (("offsets", 8), ("frequency", 1),
                                                                             ("amplitude", 1))
    again = pol.from_control(back, m)
    assert again.family == c.family
    np.testing.assert_array_equal(again.coeffs, c.coeffs)
    np.testing.assert_array_equal(again.weights, c.weights)
    assert pol.from_control(read_ctl(_write(tmp_path, THESIS_CTL)), m).shape == (8, 5)   # open loop: coefficients


@pytest.mark.parametrize("edit, line, message", [
    (lambda t: t.replace("Policy pmtg", "Policy"), 10, "expected 'Policy NAME'"),
    (lambda t: t.replace("Inputs", "Inptus"), 11, "expected the policy's 'Inputs NAME SIZE ...' line"),
    (lambda t: t.replace("bias 1\n", "bias\n", 1), 11, "NAME SIZE pairs"),
    (lambda t: t.replace("tilt 2", "tilt two"), 11, "the size of tilt must be a whole number"),
    (lambda t: t.replace("Outputs offsets 8", "Outputs offsets 8 offsets 8"), 12, "a group is named twice"),
    (lambda t: "\n".join(t.splitlines()[:-1]) + "\n", 22, "expected 10 lines of policy weights"),
    (lambda t: t + "0.1\n", 24, r"one number per input \(20\); found 1"),
    (lambda t: t + "Policy pmtg\n", 24, "a second 'Policy' line"),
])
def test_a_malformed_policy_is_named_with_its_line(tmp_path, edit, line, message):
    from cpgjax.episode import policy as pol
    from cpgjax.io.ctl import PolicyTable
    from cpgjax.io.wl import load_model

    m = load_model("models/quadruped.wl")
    c = _closed_loop(m)
    text = edit(format_ctl(c.coeffs, 0.5, exact=True, policy=PolicyTable(**pol.table_fields(c, m))))
    with pytest.raises(DescriptionError, match=message) as e:
        read_ctl(_write(tmp_path, text), n_dof=8, harmonics=2)
    assert str(e.value).startswith(f"{tmp_path / 'c.ctl'}:{line}: ")


def test_a_policy_that_does_not_fit_the_model_is_named_with_its_line(tmp_path):
    from cpgjax.episode import policy as pol
    from cpgjax.io.ctl import PolicyTable
    from cpgjax.io.wl import load_model

    m = load_model("models/quadruped.wl")
    c = _closed_loop(m)
    t = format_ctl(c.coeffs, 0.5, exact=True, policy=PolicyTable(**pol.table_fields(c, m)))
    bad = t.replace("contact 4", "contact 3").replace("phase 2", "phase 3")      # 20 inputs still, not the model's
    with pytest.raises(DescriptionError, match="do not fit the model: expected angles 8") as e:
        pol.from_control(read_ctl(_write(tmp_path, bad), n_dof=8, harmonics=2), m)
    assert str(e.value).startswith(f"{tmp_path / 'c.ctl'}:10: Inputs ")
    with pytest.raises(DescriptionError, match="unknown controller family 'ann'"):
        pol.from_control(read_ctl(_write(tmp_path, t.replace("Policy pmtg", "Policy ann")), 8, 2), m)
