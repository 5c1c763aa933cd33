"""Small `.wl` models for the physics tests (analytic cases)."""

from __future__ import annotations

import functools

import numpy as np

from cpgjax.io.wl import parse_wl
from cpgjax.sim.model import build_model

# A 13.8 kg stool on three feet: on uneven ground its pose and the feet's loads follow from statics
# (tests/crosscheck/test_mjcf.py, test_ground.py).
STOOL = """
Object Stool {
    Type Cube
    Mass 13.8
    Dimensions .2 .2 .05
    Position 0.03 0.02 0.1
    Contact -0.1 -0.08 -0.1
    Contact 0.1 -0.08 -0.1
    Contact 0.0 0.1 -0.1
}
"""


def model_from(text: str, **kw):
    return build_model(parse_wl(text, "<test>"), **kw)


def box(z=0.05, mass=10.0, gravity=9.81, friction=1.0, extra="", log_rate=20, contact=True):
    return model_from(f"""
TimeMax 2.0
LogRate {log_rate}
Friction {friction}
Gravity {gravity}
{extra}
Object Box {{
    Type Cube
    Mass {mass}
    Dimensions .1 .1 .1
    Position 0 0 {z}
    {'' if contact else 'NoContact'}
}}
""")


def pendulum(angle=0.1, length=0.5, mass=1.0, log_rate=1000):
    """A rod hanging from a fixed block on a passive revolute joint about x."""
    return model_from(f"""
TimeMax 3.0
LogRate {log_rate}
Object Rig {{
    Type Cube
    Mass 5
    Dimensions .1 .1 .1
    Position 0 0 2
    Fixed
    NoContact
}}
Object Rod {{
    Type Cube
    Mass {mass}
    Dimensions .02 .02 {length}
    NoContact
}}
Joint Hinge {{
    Rig 0 0 -.05
    Rod 0 0 {length / 2}
    Orientation {angle} 0 0
    PassiveX
}}
""")


def double_pendulum():
    """Two rods (1 kg, 0.4 m; 0.5 kg, 0.3 m) on passive joints about x, hanging from a fixed block, released
    at 1 rad and 0.5 rad: chaotic, undamped."""
    return model_from("""
TimeMax 2
LogRate 100
Object Rig {
    Type Cube
    Mass 5
    Dimensions .1 .1 .1
    Position 0 0 2
    Fixed
    NoContact
}
Object A {
    Type Cube
    Mass 1
    Dimensions .02 .02 .4
    NoContact
}
Object B {
    Type Cube
    Mass 0.5
    Dimensions .02 .02 .3
    NoContact
}
Joint J1 {
    Rig 0 0 -.05
    A 0 0 .2
    Orientation 1.0 0 0
    PassiveX
}
Joint J2 {
    A 0 0 -.2
    B 0 0 .15
    Orientation 0.5 0 0
    PassiveX
}
""")


def rig(limits=(-1.5, 1.5), time=4, servo="60 0 1 17.5"):
    """An upper leg of the quadruped on a controlled hip, hanging from a fixed block (a test rig)."""
    return model_from(f"""
TimeMax {time}
LogRate 100
Servo {servo}
Object Rig {{
    Type Cube
    Mass 5
    Dimensions .1 .1 .1
    Position 0 0 1
    Fixed
    NoContact
}}
Object Arm {{
    Type Cube
    Mass 0.5
    Dimensions .016 .035 .15
    NoContact
}}
Joint Hip {{
    Rig 0 0 -.05
    Arm 0 0 .065
    Limits {limits[0]} {limits[1]}
    ControlX
}}
""")


def chain(gravity=0.0, contact=False):
    """Three links in a row, two servo-driven joints: a free 'worm' in space."""
    nc = "" if contact else "NoContact"
    objs = "\n".join(f"""
Object L{i} {{
    Type Cube
    Mass {1.0 + 0.5 * i}
    Dimensions .05 .2 .03
    {'Position 0 0 1' if i == 0 else ''}
    {nc}
}}""" for i in range(3))
    joints = "\n".join(f"""
Joint J{i} {{
    L{i} 0 .1 0
    L{i + 1} 0 -.1 0
    ControlX
}}""" for i in range(2))
    return model_from(f"TimeMax 1.0\nGravity {gravity}\nLogRate 100\n{objs}\n{joints}\n")


def energy(model, traj):
    """Kinetic + potential energy [S] of a recorded single-robot trajectory."""
    from cpgjax.io.logs import quat_to_mat_np

    x, v, w, q = (np.asarray(traj[k], float) for k in ("x", "v", "w", "q"))
    m = model.mass
    ke = 0.5 * (m[None] * (v**2).sum(1)).sum(-1)
    rot = 0.0
    for b in range(model.nb):
        R = np.moveaxis(quat_to_mat_np(np.moveaxis(q[:, :, b], 1, 0)), -1, 0)  # [S, 3, 3]
        Iw = R @ model.inertia[:, :, b] @ np.swapaxes(R, 1, 2)
        wb = w[:, :, b]
        rot = rot + 0.5 * np.einsum("si,sij,sj->s", wb, Iw, wb)
    pe = model.gravity * (m[None] * x[:, 2]).sum(-1)
    return ke + rot + pe


def block_on_slope(slope: float, mu: float):
    """A 2 kg, 10 cm cube resting (1 mm up) on a ramp of ``slope`` rad, friction ``mu``."""
    return model_from(f"""
TimeMax 2
LogRate 50
Friction {mu}
Terrain ramp {slope}
Object Box {{
    Type Cube
    Mass 2
    Dimensions .1 .1 .1
    Position 0 1.0 {-np.tan(slope) * 1.0 + 0.05 / np.cos(slope) + 0.001}
    Orientation {-slope} 0 0
}}
""")


def period(t, angle):
    """Mean period of a recorded oscillation from its upward zero crossings (linear interpolation)."""
    s = np.sign(angle)
    idx = np.where((s[:-1] < 0) & (s[1:] >= 0))[0]
    tc = t[idx] - angle[idx] * (t[idx + 1] - t[idx]) / (angle[idx + 1] - angle[idx])
    return np.diff(tc).mean()


# Shared runs of the small analytic cases: one compiled program each for several tests (tests/sim/test_contact.py,
# tests/sim/test_variation.py), the robots of a batch differing by their :class:`Variation` only.  Every scale the
# tests compare is given (ones and zeros for the nominal robot), so each case is one tree structure, one program;
# the results are cached for the process (read them, never change them).

def varied_run(model, time: float, **fields):
    """``model``'s robots (passive: no controller) for ``time`` s, recorded, each with its own scales: ``fields``
    are Variation fields as one value per robot (``mass`` scales every body's)."""
    import jax
    import jax.numpy as jnp

    from cpgjax.episode.probes import Record
    from cpgjax.episode.rollout import rollout
    from cpgjax.sim.variation import Variation

    B = len(next(iter(fields.values())))
    f32 = lambda a: jnp.asarray(a, jnp.float32)  # noqa: E731
    var = Variation.nominal(model, B)
    scales = {"stiffness": np.ones(B), "damping": np.ones(B), **fields}
    var = var._replace(**{k: f32(v)[None] if k == "mass" else f32(v) for k, v in scales.items()})
    coeffs = jnp.zeros((model.n_ctrl, model.n_coeff, B))
    run = jax.jit(lambda v: rollout(model, coeffs, time=time, var=v, probes=(Record(),)))
    return jax.tree.map(np.asarray, run(var))


# Seven 10 kg boxes (10 cm cubes) on flat ground for 2 s, recorded at 200 Hz: resting from 5 cm (their bottom
# 0 m) with mass, the ground's stiffness A and its damping B scaled (eq. 3.7), the last one dropped from 50 cm
# (lifted 45 cm).
BOXES = dict(mass=[1.0, 0.8, 1.5, 1.0, 1.0, 1.0, 1.0], stiffness=[1.0, 1.0, 1.0, 0.5, 1.0, 1.5, 1.0],
             damping=[1.0, 1.0, 1.0, 1.5, 0.6, 1.0, 1.0], lift=[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.45])
BOX_DROPPED = 6


@functools.cache
def boxes():
    """The run of :data:`BOXES` (a dict of arrays, the robot last), made once per process."""
    return varied_run(box(z=0.05, mass=10.0, log_rate=200), 2.0, **BOXES)


# Five 2 kg blocks on a 0.3 rad ramp (tan 0.31) for 2 s, friction mu 0.4 scaled per block: mu 0.6 (sticks),
# 0.1 (slides), 0.4 (sticks), 0.24 (slides), and 0.6 again with a 100x stiffer friction bristle.
SLOPE = 0.3
SLOPES = dict(friction=[1.5, 0.25, 1.0, 0.6, 1.5], bristle=[1.0, 1.0, 1.0, 1.0, 100.0])


@functools.cache
def slopes():
    """The run of :data:`SLOPES` (``block_on_slope(SLOPE, 0.4)``), made once per process."""
    return varied_run(block_on_slope(SLOPE, 0.4), 2.0, **SLOPES)
