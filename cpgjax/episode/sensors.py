"""What the robot senses: the observation of a closed-loop controller (beyond the thesis; its Ch. 5.2, 5.4.2, 7).

The thesis's robot had joint encoders (Ch. 5.2.1), a vestibular system, two pendulums giving the body's roll
and pitch (Ch. 5.2.2), and touch sensors on the feet were its next step (Ch. 5.4.2).  The observation is what
those sensors read, in groups (a closed-loop controller reads some or all of them,
:class:`cpgjax.episode.policy.Family`), every group computed from the simulator's state alone:

- ``angles`` [n_ctrl]: the controlled joints' angles, rad (the encoders; on exact joints the generalized
  coordinates, on pivot springs measured from the bodies' poses, :func:`cpgjax.sim.joints.joint_angles`);
- ``tilt`` [2]: roll and pitch of the tracked body, rad, as the vestibular pendulums read them: a pendulum
  swinging in the body's plane of its forward (+y) and up (+z) axes hangs along gravity's projection on that plane,
  so it reads ``pitch = atan2(u_y, u_z)``, and the other, in the plane of +x and +z, ``roll = atan2(-u_x, u_z)``,
  ``u`` the world's up axis in body coordinates (a body turned by an angle a about its +x axis reads pitch a,
  about +y roll a);
- ``rates`` [2]: the roll and pitch rates, rad/s (a rate gyro: the body's angular velocity about its +y and +x
  axes);
- ``contact`` [legs]: 1 where a leg's foot touches the ground, else 0 (the touch sensors; a leg and its foot as in
  :func:`cpgjax.episode.descriptors.legs`; touching as the contact law tests it, some vertex of the foot in the
  terrain, depth > 0, or just on it, depth 0: a robot placed on the ground reads its feet down from t = 0);
- ``stance`` [legs]: each touch sensor's reading low-passed with the time constant :data:`STANCE_TAU` (eq.
  :func:`stance_update`), from its first reading on: a foot that bounces on landing, down and up within a few
  milliseconds, moves it a little, where it flips ``contact`` between 0 and 1 each time (the rollout and MuJoCo C's
  runner keep its value from step to step);
- ``phase`` [2]: ``sin`` and ``cos`` of the CPG's phase (:mod:`cpgjax.episode.policy`);
- ``command`` [1]: the commanded turning rate ``c``, rad/s (0 unless a task sets it: :mod:`cpgjax.episode.steering`);
- ``steer`` [2]: ``c sin`` and ``c cos`` of the CPG's phase: with them a linear policy can change each joint's first
  harmonic in proportion to the command (a longer stride on one side, which is how a trotting quadruped turns),
  which ``command`` alone, a constant offset, cannot;
- ``turn`` [1]: ``|c|``, how hard the robot is told to turn, whichever way: a mirror-symmetric policy
  (:mod:`cpgjax.episode.mirror`) can move its frequency and amplitude, which are the same for both sides, only by
  readings that the mirror keeps, so without ``turn`` it cannot slow its gait down in a turn;
- ``bias`` [1]: the constant 1.

A family reads every group but ``stance``, ``steer`` and ``turn`` unless it names its groups (:data:`DEFAULT_GROUPS`,
the groups that existed before them: the closed-loop runs and `.ctl` files made before them read as they did).

Each group has a scale (:data:`SCALES`): the size of a typical reading, by which the policy's weights are scaled
(:mod:`cpgjax.episode.policy`) and sensor noise is sized (:func:`noise`).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.episode.descriptors import legs
from cpgjax.sim.contact import terrain_under
from cpgjax.sim.joints import joint_angles
from cpgjax.sim.rotation import matTvec, matvec, quat_to_mat

#: The observation's groups, in the order they are stacked.
GROUPS = ("angles", "tilt", "rates", "contact", "stance", "phase", "command", "steer", "turn", "bias")
#: The groups a family reads when it names none (``--controller pmtg``).
DEFAULT_GROUPS = tuple(g for g in GROUPS if g not in ("stance", "steer", "turn"))
#: The time constant of the ``stance`` reading's low pass, s (a trotting foot is down for 100-300 ms; a bounce
#: lasts a few ms).
STANCE_TAU = 0.02
#: The typical size of a group's readings (rad, rad, rad/s, 1, 1, 1, rad/s, rad/s, rad/s, 1).
SCALES = {"angles": 1.0, "tilt": 0.5, "rates": 2.0, "contact": 1.0, "stance": 1.0, "phase": 1.0, "command": 1.0,
          "steer": 0.25, "turn": 0.25, "bias": 1.0}
#: The groups that are sensors: noise is added to them, not to the CPG's phase, the command (and ``steer``) or the
#: bias.
SENSED = ("angles", "tilt", "rates", "contact", "stance")


def sizes(model) -> dict[str, int]:
    """The number of readings of each group for ``model``."""
    return {"angles": model.n_ctrl, "tilt": 2, "rates": 2, "contact": int(legs(model)[1].shape[0]),
            "stance": int(legs(model)[1].shape[0]), "phase": 2,
            "command": 1, "steer": 2, "turn": 1, "bias": 1}


def _feet(model):
    """(contact vertices of the feet [nf], the leg of each [nf], number of legs)."""
    feet = legs(model)[1]
    leg, vert = np.nonzero(feet)
    return vert, leg, feet.shape[0]


def touch(model, s, var=None, at=None):
    """[legs, B] 1.0 where a leg's foot touches the terrain (some vertex of it at depth >= 0), else 0.0.

    ``at`` [legs, B] (m) or None: each leg's sensor reads its foot down from that depth on instead of 0 (negative: a
    little before the foot touches, positive: once it is pressed in; the perturbation ``touch``, which draws it per
    episode, so that a gait cannot live on when exactly a foot's contact begins, :mod:`cpgjax.episode.perturb`).
    """
    vert, leg, n_legs = _feet(model)
    B = s.x.shape[-1]
    if n_legs == 0:
        return jnp.zeros((0, B), s.x.dtype)
    pts = np.asarray(model.ct_pt)[vert]
    body = np.asarray(model.pt_body)[pts]
    R = quat_to_mat(s.q[:, body])                                       # [3, 3, nf, B]
    p = s.x[:, body] + matvec(R, jnp.asarray(model.pt_local[:, pts], s.x.dtype)[:, :, None])
    if at is not None:
        depth = -p[2] if model.terrain.flat else terrain_under(model, p[0], p[1], var)[0] - p[2]
        down = depth >= jnp.asarray(at, depth.dtype)[leg]
    elif model.terrain.flat:
        down = p[2] <= 0
    else:
        zg, _ = terrain_under(model, p[0], p[1], var)
        down = zg - p[2] >= 0
    out = []
    for k in range(n_legs):                                             # any vertex of the leg's foot
        idx = np.nonzero(leg == k)[0]
        d = down[idx[0]]
        for i in idx[1:]:
            d = d | down[i]
        out.append(d)
    return jnp.stack(out).astype(s.x.dtype)


def vestibular(model, s):
    """Roll, pitch [2, B] (rad) and their rates [2, B] (rad/s) of the tracked body (see the module docstring)."""
    q = s.q[:, model.track]
    R = quat_to_mat(q)                                                  # [3, 3, B]: body axes in world columns
    ux, uy, uz = R[2, 0], R[2, 1], R[2, 2]                              # the world's up in body coordinates
    wb = matTvec(R, s.w[:, model.track])                                # angular velocity in body coordinates
    return jnp.stack([jnp.arctan2(-ux, uz), jnp.arctan2(uy, uz)]), jnp.stack([wb[1], wb[0]])


def angles(model, s):
    """[n_ctrl, B] the controlled joints' angles (rad)."""
    if s.exact is not None:
        return s.exact.angle[model.ctrl_joint]
    R = quat_to_mat(s.q)
    return joint_angles(model, R, s.w)[0][model.ctrl_joint]


def stance_update(model, prev, touch_now):
    """The ``stance`` reading after a step: ``prev + a (touch - prev)``, ``a = min(1, dt / STANCE_TAU)`` with ``dt``
    the model's step (the control period); numpy or JAX arrays, [legs, ...]."""
    a = min(1.0, float(model.dt) / STANCE_TAU)
    return prev + a * (touch_now - prev)


def observe(model, groups, s, var, phase, command, touch_at=None, stance=None):
    """The observation [n, B]: the readings of ``groups`` (in :data:`GROUPS` order) stacked.

    ``phase``: (sin, cos) [B] of the CPG's phase; ``command`` [B] the commanded turning rate; ``touch_at`` [legs, B]
    or None: the depth from which each touch sensor reads (:func:`touch`); ``stance`` [legs, B]: the ``stance``
    reading, kept by the caller (:func:`stance_update`); None: the touch sensors' reading, its first value.
    """
    parts = []
    tilt = rates = None
    for g in GROUPS:
        if g not in groups:
            continue
        if g == "angles":
            parts.append(angles(model, s))
        elif g in ("tilt", "rates"):
            if tilt is None:
                tilt, rates = vestibular(model, s)
            parts.append(tilt if g == "tilt" else rates)
        elif g == "contact" or (g == "stance" and stance is None):
            parts.append(touch(model, s, var, touch_at))
        elif g == "stance":
            parts.append(stance)
        elif g == "phase":
            parts.append(jnp.stack(phase))
        elif g == "command":
            parts.append(command[None])
        elif g == "steer":
            parts.append(jnp.stack(phase) * command[None])
        elif g == "turn":
            parts.append(jnp.abs(command)[None])
        else:
            parts.append(jnp.ones((1,) + command.shape, command.dtype))
    return jnp.concatenate(parts, 0)


def noise_scale(model, groups) -> np.ndarray:
    """[n] the sensor-noise amplitude of each reading per unit of noise: ``sqrt(3)`` times its group's scale
    (uniform noise of that half-width has the standard deviation of the scale), 0 for what is not a sensor."""
    n = sizes(model)
    return np.concatenate([np.full(n[g], math.sqrt(3.0) * SCALES[g] if g in SENSED else 0.0)
                           for g in GROUPS if g in groups]).astype(np.float32)


def noise(key, step, amplitude):
    """Sensor noise [n, B] of one step: ``amplitude`` [n] times ``U(-1, 1)`` drawn per robot from its key.

    ``key`` [2, B] uint32 (the raw data of each robot's key), ``step`` []: the step count, folded into each key,
    so the draws depend only on the robot's key and the step (reproducible, and independent of the batch).
    """
    def one(k):
        kk = jax.random.fold_in(jax.random.wrap_key_data(k), step)
        return jax.random.uniform(kk, amplitude.shape, jnp.float32, -1.0, 1.0)

    u = jax.vmap(one, in_axes=1, out_axes=1)(key)
    return jnp.asarray(amplitude)[:, None] * u
