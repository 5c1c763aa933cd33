"""A damaged robot (beyond the thesis): what ``cpgjax adapt --damage`` breaks, hidden from the search.

Cully et al. (Nature 2015) damaged their hexapod (a leg cut short or removed, a motor unpowered) and let
the robot find a new gait by trial without diagnosing the damage.  Here a damage is an edit of the model
(its :class:`~cpgjax.sim.description.Description`) or of what reaches its servos, applied inside the
evaluation, so that a search sees only each trial's fitness:

================== ===========================================================================
``leg=AR``         the leg ``AR`` (a leg's name: its hip joint's name without the prefix the hip
                   joints share, :func:`cpgjax.episode.descriptors.legs`) no longer touches the
                   ground: every contact vertex of its bodies is removed (as if cut off at the hip;
                   its mass stays on the robot)
``locked=KneeAR``  the joint's servo holds it at its initial angle whatever the controller says
                   (its row of CPG coefficients is zeroed before the episode)
``weak=HipPL:0.3`` the joint's servo gives at most 0.3 of its torque (``tau_max`` scaled)
================== ===========================================================================

Several damages are joined with ``,`` (``leg=AR,weak=HipPL:0.5``); ``none`` is the intact robot.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from cpgjax.episode.descriptors import legs
from cpgjax.sim.description import Description, ServoDef

KINDS = ("leg", "locked", "weak")


@dataclass(frozen=True)
class Damage:
    """One damage: ``kind`` in :data:`KINDS`, the leg's or joint's name, the torque factor (``weak``)."""

    kind: str
    target: str
    factor: float = 1.0

    def __str__(self) -> str:
        return f"{self.kind}={self.target}" + (f":{self.factor:g}" if self.kind == "weak" else "")


def parse(text: str | None, model) -> tuple[Damage, ...]:
    """The damages of ``text`` (``leg=AR,locked=KneeAR,weak=HipPL:0.3``; ``none``/empty: none) for ``model``.

    Bad input: ``ValueError`` naming the part that is wrong and what is allowed.
    """
    if text is None or text.strip() in ("", "none"):
        return ()
    leg_names = legs(model)[0]
    joints = [model.joint_names[int(j)] for j in np.asarray(model.ctrl_joint)]
    out = []
    for part in text.split(","):
        part = part.strip()
        kind, eq, rest = part.partition("=")
        if not eq or kind not in KINDS:
            raise ValueError(f"--damage {part!r}: expected KIND=NAME with KIND one of {', '.join(KINDS)} "
                             "(leg=AR, locked=KneeAR, weak=HipPL:0.3)")
        if kind == "leg":
            if rest not in leg_names:
                raise ValueError(f"--damage {part!r}: no leg {rest!r}; the model's legs are {', '.join(leg_names)}")
            out.append(Damage("leg", rest))
            continue
        name, colon, factor = rest.partition(":")
        if name not in joints:
            raise ValueError(f"--damage {part!r}: no controlled joint {name!r}; the model's are {', '.join(joints)}")
        if kind == "locked":
            if colon:
                raise ValueError(f"--damage {part!r}: locked takes no factor (locked={name})")
            out.append(Damage("locked", name))
            continue
        if not colon:
            raise ValueError(f"--damage {part!r}: weak needs the torque factor (weak={name}:0.3)")
        try:
            f = float(factor)
        except ValueError:
            raise ValueError(f"--damage {part!r}: the torque factor {factor!r} is not a number") from None
        if not 0.0 <= f < 1.0:
            raise ValueError(f"--damage {part!r}: the torque factor must be in [0, 1) (1 is no damage), got {f:g}")
        out.append(Damage("weak", name, f))
    return tuple(out)


def describe(damages) -> str:
    """``leg=AR,weak=HipPL:0.3`` (``none`` for the intact robot): the text :func:`parse` reads back."""
    return ",".join(str(d) for d in damages) or "none"


def damaged_description(desc: Description, model, damages) -> Description:
    """The description of the damaged robot (``leg`` and ``weak``; ``locked`` acts on the controller:
    :func:`controller_mask`).  ``model`` is the intact robot built from ``desc``."""
    objects, joints = dict(desc.objects), list(desc.joints)
    names, _, bodies = legs(model)
    for d in damages:
        if d.kind == "leg":
            for b in bodies[names.index(d.target)]:
                body = model.body_names[b]
                members = desc.compounds[body].objects if body in desc.compounds else (body,)
                for o in members:
                    objects[o] = dataclasses.replace(objects[o], contacts=())
        elif d.kind == "weak":
            i = next(k for k, j in enumerate(joints) if j.name == d.target)
            sv: ServoDef = joints[i].servo or desc.servo
            joints[i] = dataclasses.replace(joints[i], servo=dataclasses.replace(sv, tau_max=sv.tau_max * d.factor))
    return dataclasses.replace(desc, objects=objects, joints=joints)


def controller_mask(model, damages) -> np.ndarray:
    """[n_ctrl, 2K+1] float32: 1, and 0 on the rows of ``locked`` joints (their target stays 0)."""
    mask = np.ones((model.n_ctrl, model.n_coeff), np.float32)
    ctrl = [model.joint_names[int(j)] for j in np.asarray(model.ctrl_joint)]
    for d in damages:
        if d.kind == "locked":
            mask[ctrl.index(d.target)] = 0.0
    return mask
