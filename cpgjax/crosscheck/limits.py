"""Joint limits in MuJoCo as ours are: a penalty spring and damper beyond the limit.

Ours (``sim/joints.py``, ``sim/exact/step.py``) push a joint back past its limit with the torque
``-k r - c qdot``, ``k`` = ``Model.limit_k`` (300 N m/rad) and ``c`` = ``Model.limit_c`` (3 N m s/rad), ``r`` how
far past it is.  MuJoCo enforces a limit as a soft constraint, and its defaults (``solreflimit`` 0.02 s, damping
ratio 1) are far softer: a saturated servo holds a rig's arm 0.058 rad past its stop here and 0.111 rad in MuJoCo
(``tests/crosscheck/test_limits.py``), and evolved gaits' joints went up to 0.52 rad past it in MuJoCo on 2 cm
fields where ours went 0.09 (docs/results/joint-limits.md).

MuJoCo's constraint solves ``(A + R) f = a_ref - a0`` for the limit's force ``f``, with ``R = (1 - d)/d W``,
``W`` the joint's ``dof_invweight0``, and in the direct form (``solref = -s0 -s1``, ``solimp = d d ...``)
``a_ref = -(s1/d) v - (s0/d) r``.  For ``d`` small ``R`` dominates and ``f = -(s0 r + s1 v)/W - d (...)``: a
penalty torque.  So ``s0 = k W`` and ``s1 = c W`` with ``d`` = :data:`IMPEDANCE` give ours within ``d``.

MuJoCo's constraint force is explicit in velocity: its damping is stable only while ``c W dt`` stays below 2,
where ours is implicit (``sim.joints.implicit_damping``).  The export caps ``c W dt`` at :data:`DAMPING_STEP`
(the bound MuJoCo's ``refsafe`` sets on its standard form): on the quadruped's knees that is 85 % of ours at
0.25 ms and 11 % at the default 2 ms.  Two smaller differences stay: MuJoCo's limit only pushes (ours also pulls
while a joint leaves its limit faster than ``k r / c``), and ``d`` is not zero.

``joint_limit("mujoco")`` exports MuJoCo's default limit instead, as every export before this module did.
"""

from __future__ import annotations

import contextvars
import xml.etree.ElementTree as ET

import numpy as np

from cpgjax.crosscheck.scoped import scoped

#: how a joint limit is exported: ``penalty`` (ours, as this module derives it) or ``mujoco`` (MuJoCo's default)
LIMITS = ("penalty", "mujoco")
IMPEDANCE = 1e-4  # MuJoCo's smallest solimp (mjMINIMP): the limit is a penalty within 0.01 %
DAMPING_STEP = 1.0  # at most this much of the limit's damping per step (c W dt), as MuJoCo's refsafe allows
_LIMIT: contextvars.ContextVar[str] = contextvars.ContextVar("mujoco_limit", default="penalty")


def check_limit(form: str) -> str:
    if form not in LIMITS:
        raise ValueError(f"MuJoCo's joint limit must be one of {', '.join(LIMITS)}, got {form!r}")
    return form


def current_limit() -> str:
    """The joint limit the export uses: ``penalty``, or the one of an enclosing :func:`joint_limit`."""
    return _LIMIT.get()


def joint_limit(form: str | None):
    """Within this block every export gives MuJoCo this joint limit (None: as exported, ``penalty``)."""
    return scoped(_LIMIT, None if form is None else check_limit(form))


def limit_solref(k: float, c: float, invweight: float, timestep: float) -> tuple[float, float]:
    """MuJoCo's direct ``solreflimit`` ``(-s0, -s1)`` for a penalty ``k`` [N m/rad], ``c`` [N m s/rad] on a joint
    of ``dof_invweight0`` ``invweight``, its damping capped at :data:`DAMPING_STEP` per ``timestep``."""
    return -k * invweight, -min(c * invweight, DAMPING_STEP / timestep)


def _bodies_only(root: ET.Element) -> ET.Element:
    """``root`` without its ground (the world's geoms and the assets they use), which ``dof_invweight0`` does not
    depend on: a mesh ground takes MuJoCo seconds to compile."""
    slim = ET.Element(root.tag, root.attrib)
    for child in root:
        if child.tag == "worldbody":
            world = ET.SubElement(slim, "worldbody", child.attrib)
            world.extend(c for c in child if c.tag != "geom")
        elif child.tag != "asset":
            slim.append(child)
    return slim


def set_limits(root: ET.Element, joints: dict[str, ET.Element], k: float, c: float, timestep: float) -> None:
    """Give each limited hinge in ``joints`` (name -> its ``joint`` element in ``root``) the penalty limit
    ``k``, ``c``: the tree compiled once by MuJoCo for its ``dof_invweight0``."""
    import mujoco

    limited = {n: el for n, el in joints.items() if "range" in el.attrib}
    if not limited or current_limit() == "mujoco":
        return
    mj = mujoco.MjModel.from_xml_string(ET.tostring(_bodies_only(root), encoding="unicode"))
    for name, el in limited.items():
        jid = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_JOINT, name)
        w = float(mj.dof_invweight0[mj.jnt_dofadr[jid]])
        if not np.isfinite(w) or w <= 0:
            continue
        s0, s1 = limit_solref(k, c, w, timestep)
        el.set("solreflimit", f"{s0:.9g} {s1:.9g}")
        el.set("solimplimit", f"{IMPEDANCE:g} {IMPEDANCE:g} 0.001 0.5 2")
