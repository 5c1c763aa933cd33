"""Export a `.wl` model to MJCF, for MuJoCo (C) and MJX (the independent reference engine).

How the penalty model maps onto MuJoCo's:

- bodies: the kinematic tree of the joints (MuJoCo needs one); root bodies get a free
  joint (or none when ``Fixed``); each body's frame is the `.wl` frame, its ``inertial``
  the same mass, CM and full inertia tensor;
- joints: hinges at the second body's pivot, about the joint axis, with the same limits, which MuJoCo
  enforces as soft constraints tuned to act as our penalty torques (:mod:`cpgjax.crosscheck.limits`);
- servo: a ``position`` actuator per controlled joint with the same kp, kv = kd and force
  range +-tau_max.  MuJoCo's is ``kp (u - q) - kv qdot``; ours has ``kd (q*' - qdot)``: feeding
  ``u = q* + (kd/kp) q*'`` makes them equal below saturation (see ``servo_ctrl``);
- contact: a sphere of ``CONTACT_RADIUS`` centred on each contact vertex (MuJoCo collides geoms,
  not points), the same friction coefficient, and ``solref = -A/m_c -B/m_c`` in MuJoCo's direct
  stiffness/damping form (see ``contact_solref``: MuJoCo's are per unit mass, eq. 3.7's are forces);
- terrain: a plane when flat, else an ``hfield`` sampled from our bilinear surface on a grid
  ``hfield_sub`` times finer than ours (MuJoCo triangulates each cell; see ``hfield_grid``); either
  lies ``CONTACT_RADIUS`` below our ground, so that a sphere's lowest point rests where our vertex does.
  ``ground="mesh"`` or ``"boxes"`` gives the same surface as convex pieces instead (:mod:`cpgjax.crosscheck.ground`);
  ledges (stairs, a bar, a gap: ``sim.ledges``) are boxes, shrunk by the same radius (``ground.ledge_boxes``).

Why 1 cm spheres, not points: MuJoCo's soft contact lets a loaded foot sink 1.9 mm (median; 5.9 mm at the 99th
percentile) while the quadruped trots on flat ground, and a heightfield is a union of triangular prisms, each
collided with the sphere on its own.  A sphere whose centre sinks below the top of a prism beside it is pushed
out through that prism's vertical wall, sideways: a 2 mm foot got stuck in the ground (on 2 cm roughness 75 %
of its contacts pointed more than 45 degrees from vertical, and the trot walked 0.36 m in 10 s where it walks
1.3-1.4 m in our simulator); with a 1 cm sphere 0.6 % (1.48 m).  On a plane the lowered ground makes the
sphere a point foot at the vertex (docs/crosscheck.md, *Rough ground*).
- looks: the objects' boxes/cylinders as visual geoms (no contact, no mass).
"""

from __future__ import annotations

import contextvars
import xml.etree.ElementTree as ET

import numpy as np

from cpgjax.crosscheck.ground import add_ground, check_form, course_ground, current_form, hfield_geom, ledge_boxes
from cpgjax.crosscheck.limits import set_limits
from cpgjax.crosscheck.scoped import scoped
from cpgjax.sim.course import rough_spans
from cpgjax.sim.rotation import euler_to_mat, mat_to_quat
from cpgjax.sim.terrain import EXTENT_X, EXTENT_Y

CONTACT_RADIUS = 0.01  # m: the foot spheres, larger than MuJoCo lets a loaded foot sink (see above)
MJ_TIMESTEP = 0.002  # s: MuJoCo's default step, stable for this robot
HFIELD_SUB = 4  # heightfield points per cell of ours, along x and y: MuJoCo's triangles within 0.86 mm of our
#                 bilinear surface on 4 cm roughness (3.2 mm at 2, 14 mm at 1), tests/crosscheck/test_mjcf.py
HFIELD_POINTS = 200_000  # at most this many heightfield points: fewer subdivisions on finer grids


def _f(v) -> str:
    return " ".join(f"{float(x):.9g}" for x in np.ravel(v))


def contact_mass(model, tol: float = 1e-3) -> float:
    """The mass each resting contact carries [kg]: the free bodies' mass over the contact vertices that
    touch in the design pose (within ``tol`` of the lowest; the quadruped: 13.8 kg on 4 feet)."""
    free = ~np.asarray(model.fixed, bool)
    m = float(np.asarray(model.mass)[free].sum())
    if m == 0.0 or len(model.ct_pt) == 0:
        return 1.0
    from cpgjax.sim.rotation import quat_to_mat_np

    b = model.pt_body[model.ct_pt]
    R = quat_to_mat_np(np.asarray(model.q0)[:, b])                  # [3, 3, nc]
    z = np.asarray(model.x0)[2, b] + np.einsum("ij...,j...->i...", R, np.asarray(model.pt_local)[:, model.ct_pt])[2]
    z = z[free[b]] if free[b].any() else z
    return m / max(int(np.sum(z <= z.min() + tol)), 1)


_STIFFNESS: contextvars.ContextVar[float] = contextvars.ContextVar("mujoco_stiffness", default=1.0)

#: MuJoCo's friction cones: ``pyramidal`` (MuJoCo's default, the export's) or ``elliptic`` (the circular cone
#: ``|f_t| <= mu f_r`` that ours is).  With the pyramidal cone MuJoCo's regularisation mixes the friction
#: coefficient into the normal direction: the standing quadruped's feet rest 1.40 mm deep at mu = 2.5 and
#: 0.135 mm at mu = 1 or with the elliptic cone at any mu (tests/crosscheck/test_mjcf_cone.py).
CONES = ("pyramidal", "elliptic")
_CONE: contextvars.ContextVar[str] = contextvars.ContextVar("mujoco_cone", default="pyramidal")


#: Above this friction coefficient the pyramidal cone's ground gives way: the standing quadruped rests 2.8 mm deep at
#: mu 3, 8.4 mm at 4 and 22 mm at 5, where its trot no longer walks (docs/results/friction-cone.md).
PYRAMID_MU_MAX = 3.0


def cone_note(mu: float, cone: str | None = None, flag: str = "--mujoco-cone") -> str | None:
    """A one-line note when MuJoCo runs the pyramidal cone (``cone``, else the enclosing :func:`friction_cone`'s) on
    a ground of friction ``mu`` above :data:`PYRAMID_MU_MAX`, else None; ``flag``: the option that fixes it."""
    if (current_cone() if cone is None else check_cone(cone)) != "pyramidal" or mu <= PYRAMID_MU_MAX:
        return None
    return (f"note: the model's friction {mu:g} is above {PYRAMID_MU_MAX:g}, where MuJoCo's pyramidal friction cone "
            f"lets its ground give way (feet sink centimetres); add {flag} elliptic (docs/crosscheck.md, "
            "the friction cone)")


def check_cone(cone: str) -> str:
    if cone not in CONES:
        raise ValueError(f"MuJoCo's friction cone must be one of {', '.join(CONES)}, got {cone!r}")
    return cone


def current_cone() -> str:
    """The cone the export uses when none is given: ``pyramidal``, or the one of an enclosing :func:`friction_cone`."""
    return _CONE.get()


def friction_cone(cone: str | None):
    """Within this block every export gives MuJoCo this friction cone (None: as exported, pyramidal)."""
    return scoped(_CONE, None if cone is None else check_cone(cone))


def contact_stiffness(scale: float | None):
    """Within this block every export scales MuJoCo's contact ``solref`` (stiffness and damping alike) by ``scale``
    (None or 1: as :func:`contact_solref` derives it): a ground as stiff as ours in MuJoCo's feet's depth, to see
    whether the depth decides a verdict (``cpgjax agreement --mujoco-stiffness``; docs/results/walker.md)."""
    if scale is not None and not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"MuJoCo's contact stiffness scale must be a number > 0, got {scale}")
    return scoped(_STIFFNESS, None if scale is None else float(scale))


def contact_solref(model) -> str:
    """MuJoCo's direct ``solref = "-k -b"`` for eq. 3.7's ground ``f = A d - B v``.

    MuJoCo's direct stiffness and damping set a reference *acceleration* ``a_ref = -b v - k r`` of the
    contact, whatever mass it carries; eq. 3.7's ``A`` and ``B`` are a force per metre and per metre per
    second.  So ``k = A / m_c`` and ``b = B / m_c`` with ``m_c`` the mass a resting contact carries
    (:func:`contact_mass`): then the robot standing on its contacts bounces on MuJoCo's ground at the
    frequency and damping ratio it has on ours, ``sqrt(n A / m)`` and ``n B / (2 sqrt(n A m))``
    (``tests/crosscheck/test_mjcf.py``).  Writing ``-A -B`` directly, as before, made the quadruped's ground
    3.45x too stiff and too damped in MuJoCo.  At rest MuJoCo's depth is set by its regularisation, not by ``k``
    alone: the standing quadruped's feet sink 4.1x deeper than eq. 3.7 says (docs/results/engine-agreement.md,
    *MuJoCo's ground at rest*).
    """
    mc, scale = contact_mass(model), _STIFFNESS.get()        # scale: contact_stiffness's, 1 as exported
    return f"{-model.ground_A * scale / mc:.6g} {-model.ground_B * scale / mc:.6g}"


def hfield_grid(terrain, sub: int | None = None):
    """(heights [ny, nx], x0, y0, dx, dy): the heightfield exported for ``terrain``, our surface sampled.

    MuJoCo splits each heightfield cell into two triangles; our surface is bilinear in each cell
    (Appendix A), which differs from them by up to a quarter of the cell's twist ``h00 - h01 - h10 + h11``:
    half the range of a rough field.  Sampled ``sub`` times per cell of ours along x and y, MuJoCo's triangles
    are within ``1/sub^2`` of that.  ``sub`` defaults to :data:`HFIELD_SUB`, fewer where the grid would exceed
    :data:`HFIELD_POINTS` points.  MuJoCo has no ground beyond its heightfield, ours keeps the height of the
    nearest edge: the grid is extended by whole cells of ours to cover the workspace (``sim.terrain.EXTENT_X``,
    ``EXTENT_Y``: a bump's grid is only the bump and 10 cm either side), where that fits in the points.
    """
    ny0, nx0 = terrain.heights.shape
    dx, dy = terrain.dx, terrain.dy
    lo_x = max(0, int(np.ceil((terrain.x0 - EXTENT_X[0]) / dx - 1e-9)))
    hi_x = max(0, int(np.ceil((EXTENT_X[1] - (terrain.x0 + dx * (nx0 - 1))) / dx - 1e-9)))
    lo_y = max(0, int(np.ceil((terrain.y0 - EXTENT_Y[0]) / dy - 1e-9)))
    hi_y = max(0, int(np.ceil((EXTENT_Y[1] - (terrain.y0 + dy * (ny0 - 1))) / dy - 1e-9)))
    if (ny0 + lo_y + hi_y) * (nx0 + lo_x + hi_x) > HFIELD_POINTS:
        lo_x = hi_x = lo_y = hi_y = 0
    nx, ny = nx0 + lo_x + hi_x, ny0 + lo_y + hi_y
    x0, y0 = terrain.x0 - lo_x * dx, terrain.y0 - lo_y * dy
    if sub is None:
        sub = HFIELD_SUB
        while sub > 1 and ((ny - 1) * sub + 1) * ((nx - 1) * sub + 1) > HFIELD_POINTS:
            sub -= 1
    if sub == 1 and nx == nx0 and ny == ny0:
        return np.asarray(terrain.heights, float), x0, y0, dx, dy
    xs = x0 + dx * np.arange((nx - 1) * sub + 1) / sub
    ys = y0 + dy * np.arange((ny - 1) * sub + 1) / sub
    X, Y = np.meshgrid(xs, ys)
    return np.asarray(terrain.height_np(X, Y), float), x0, y0, dx / sub, dy / sub


def to_mjcf(model, *, timestep: float = MJ_TIMESTEP, contact_radius: float = CONTACT_RADIUS,
            hfield_sub: int | None = None, ground: str | None = None, cone: str | None = None) -> str:
    """MJCF text of a cpgjax Model (built from a `.wl` Description).

    ``ground``: the form of a non-flat ground, ``hfield``, ``mesh`` or ``boxes`` (:mod:`cpgjax.crosscheck.ground`;
    None: ``hfield``, or the form of an enclosing ``ground.ground_form``).  ``contact_radius``: the foot spheres'
    radius (the ground lies that much lower); ``hfield_sub``: the heightfield's points per cell of ours
    (:func:`hfield_grid`).  These two are for experiments (docs/crosscheck.md, *Rough ground*); the defaults are
    the export.  ``cone``: MuJoCo's friction cone (:data:`CONES`; None: pyramidal, or the cone of an enclosing
    :func:`friction_cone`)."""
    desc = model.description
    root = ET.Element("mujoco", model=desc.path.rsplit("/", 1)[-1] if desc else "cpgjax")
    ET.SubElement(root, "compiler", angle="radian", autolimits="true", inertiafromgeom="false")
    opt = ET.SubElement(root, "option", timestep=f"{timestep:g}", gravity=f"0 0 {-model.gravity:g}",
                        integrator="implicitfast")
    if (current_cone() if cone is None else check_cone(cone)) == "elliptic":
        opt.set("cone", "elliptic")
    default = ET.SubElement(root, "default")
    ET.SubElement(default, "geom", contype="0", conaffinity="0", group="1", density="0")
    mu = model.mu_static
    solref = contact_solref(model)
    asset = ET.SubElement(root, "asset")
    world = ET.SubElement(root, "worldbody")
    ET.SubElement(world, "light", pos="0 0 3", dir="0 0 -1")
    t = model.terrain
    r = float(contact_radius)
    attrs = {"contype": "1", "conaffinity": "1", "friction": f"{mu:g} 0.005 0.0001", "solref": solref}
    form = current_form() if ground is None else check_form(ground)
    if t.flat:
        ET.SubElement(world, "geom", name="ground", type="plane", size="20 20 0.1", pos=f"0 0 {-r:.9g}", contype="1",
                      conaffinity="1", friction=f"{mu:g} 0.005 0.0001", solref=solref, rgba=".8 .8 .8 1")
    elif t.heights is None:                 # ledges alone: boxes, whatever the form
        ledge_boxes(world, t.ledges, radius=r, attrs=attrs)
    elif t.ledges is not None:              # a course with rough items: boxes and a heightfield over each
        if not t.spec.startswith("course:") or "+" in t.spec:
            raise ValueError(f"terrain {t.spec!r}: MuJoCo's export has no form for a heightfield with ledges")
        course_ground(asset, world, t, rough_spans(t.spec), radius=r, attrs=attrs)
    elif form == "hfield":
        hfield_geom(asset, world, hfield_grid(t, hfield_sub), radius=r, attrs=attrs)
    else:
        add_ground(asset, world, model, form, hfield_grid(t, hfield_sub), radius=r, attrs=attrs)

    children = {int(b): j for j, b in enumerate(model.j_b)}
    joints: dict[str, ET.Element] = {}
    kids: dict[int, list[int]] = {}
    for j, a in enumerate(model.j_a):
        kids.setdefault(int(a), []).append(j)

    def frame_pose(i):
        R = _quat_mat(model.q0[:, i])
        return model.x0[:, i] - R @ model.cm_local[:, i], R

    def add_body(parent, i):
        name = model.body_names[i]
        if i in children:
            j = children[i]
            jd = desc.joints[j]
            pos = np.asarray(jd.pivot_a) - np.asarray(jd.pivot_b)  # design pose: same orientation as a
            el = ET.SubElement(parent, "body", name=name, pos=_f(pos))
            lo, hi = model.j_lo[j], model.j_hi[j]
            attrs = {"name": model.joint_names[j], "type": "hinge", "pos": _f(jd.pivot_b),
                     "axis": _f(model.j_axis[:, j])}
            if np.isfinite(lo) and np.isfinite(hi):
                attrs["range"] = f"{lo:g} {hi:g}"
            joints[model.joint_names[j]] = ET.SubElement(el, "joint", **attrs)
        else:
            p, R = frame_pose(i)
            el = ET.SubElement(parent, "body", name=name, pos=_f(p), quat=_f(mat_to_quat(R)))
            if not model.fixed[i]:
                ET.SubElement(el, "freejoint", name=f"{name}_free")
        I = model.inertia[:, :, i]
        ET.SubElement(el, "inertial", pos=_f(model.cm_local[:, i]), mass=f"{model.mass[i]:.9g}",
                      fullinertia=_f([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]))
        _visuals(el, desc, name)
        for k, pt in enumerate(model.ct_pt):
            if model.pt_body[pt] == i:
                ET.SubElement(el, "geom", name=f"{name}_c{k}", type="sphere", size=f"{r:g}",
                              pos=_f(model.pt_local[:, pt] + model.cm_local[:, i]), contype="1", conaffinity="0",
                              friction=f"{mu:g} 0.005 0.0001", solref=solref, group="3")
        for j in kids.get(i, []):
            add_body(el, int(model.j_b[j]))

    for i in range(model.nb):
        if i not in children:
            add_body(world, i)
    act = ET.SubElement(root, "actuator")
    for c, j in enumerate(model.ctrl_joint):
        ET.SubElement(act, "position", name=f"servo{c}", joint=model.joint_names[j], kp=f"{model.j_kp[j]:g}",
                      kv=f"{model.j_kd[j]:g}", forcerange=f"{-model.j_taumax[j]:g} {model.j_taumax[j]:g}",
                      ctrlrange="-10 10")
    set_limits(root, joints, float(model.limit_k), float(model.limit_c), timestep)
    ET.indent(root)
    return ET.tostring(root, encoding="unicode")


def _visuals(el, desc, body_name):
    if desc is None:
        return
    members = desc.compounds[body_name].objects if body_name in desc.compounds else (body_name,)
    for m in members:
        o = desc.objects[m]
        inside = body_name in desc.compounds
        pos = _f(o.position) if inside else "0 0 0"
        quat = _f(mat_to_quat(euler_to_mat(*o.orientation))) if inside else "1 0 0 0"
        t = o.type.lower()
        if t == "cube":
            ET.SubElement(el, "geom", type="box", size=_f(np.asarray(o.dimensions) / 2), pos=pos, quat=quat)
        elif t == "cylinder":
            r, length = o.dimensions
            q = mat_to_quat(euler_to_mat(*o.orientation) @ euler_to_mat(0, np.pi / 2, 0)) if inside else \
                mat_to_quat(euler_to_mat(0, np.pi / 2, 0))
            ET.SubElement(el, "geom", type="cylinder", size=f"{r:g} {length / 2:g}", pos=pos, quat=_f(q))
        else:
            ET.SubElement(el, "geom", type="sphere", size=f"{o.dimensions[0]:g}", pos=pos, quat=quat)


def _quat_mat(q):
    from cpgjax.sim.rotation import quat_to_mat_np

    return quat_to_mat_np(q)


def initial_qpos(model, mj) -> np.ndarray:
    """qpos0 of the exported model with the `.wl` initial joint angles."""
    import mujoco

    q = mj.qpos0.copy()
    for j, name in enumerate(model.joint_names):
        jid = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_JOINT, name)
        q[mj.jnt_qposadr[jid]] = model.j_q0[j]
    return q


def load(model, **kw):
    """A ``mujoco.MjModel`` of a cpgjax Model."""
    import mujoco

    return mujoco.MjModel.from_xml_string(to_mjcf(model, **kw))
