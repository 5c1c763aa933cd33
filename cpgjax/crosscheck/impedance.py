"""MuJoCo's contact stiffness per unit mass, and eq. 3.7's per contact (``--mujoco-contact``).

Eq. 3.7's ground pushes a touching vertex with ``f = A d - B v``: a force per metre and per metre per second,
whatever the vertex carries.  MuJoCo's direct ``solref = "-k -b"`` sets a reference *acceleration*
``a_ref = -b v - k r`` of the contact, so its force per metre is ``k`` times the contact's own effective mass
``m = 1 / (J M^-1 J^T)``: light where the joints let the foot give, heavy where a straight leg carries the body.

- ``resting`` (the export's default, :func:`cpgjax.crosscheck.mjcf.contact_solref`): ``k = A / m_c`` and
  ``b = B / m_c`` with ``m_c`` the mass a resting contact carries (a quarter of the quadruped, 3.45 kg).  The
  standing robot then bounces on MuJoCo's ground as on ours, but a contact whose effective mass is ``m`` meets a
  ground ``m / m_c`` as stiff and as damped as eq. 3.7's: a walking foot's is a fraction of ``m_c``
  (docs/crosscheck.md, *The ground's units*).
- ``per-contact``: before every step, each contact sphere that touched at the step before gets
  ``k = A / m`` and ``b = B / m`` with ``m`` its own effective mass along the vertical, taken from MuJoCo's state
  (``mj_jac``, ``mj_solveM``): each contact's force per metre of depth is eq. 3.7's, as on our ground.  MuJoCo
  gives a contact of two direct ``solref`` the stiffer of the two (whatever ``solmix`` says), so the ground's is
  made the softest there is (``-1e-12``): a contact takes its sphere's.

MuJoCo C's side only (the ``MjModel``'s ``geom_solref`` set between steps, its public API: the law changes the
model it is given); MJX keeps ``resting``.
"""

from __future__ import annotations

import contextvars

import numpy as np

from cpgjax.crosscheck.scoped import scoped

CONTACT_LAWS = ("resting", "per-contact")
_LAW: contextvars.ContextVar[str] = contextvars.ContextVar("mujoco_contact", default="resting")


def check_law(law: str) -> str:
    """``law`` if it is one of :data:`CONTACT_LAWS`, else ValueError naming them."""
    if law not in CONTACT_LAWS:
        raise ValueError(f"unknown MuJoCo contact law {law!r}; expected one of {', '.join(CONTACT_LAWS)}")
    return law


def current_law() -> str:
    """The contact law MuJoCo C's runs use: ``resting``, or the one of an enclosing :func:`contact_law`."""
    return _LAW.get()


def contact_law(law: str | None):
    """Within this block MuJoCo C's runs (and the exports they load) use ``law`` (None: unchanged)."""
    return scoped(_LAW, None if law is None else check_law(law))


def contact_geoms(model, mj) -> np.ndarray:
    """The ids of the exported contact spheres (``BODY_cK``, one per contact vertex of ``model``)."""
    import mujoco

    ids = [mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_GEOM, f"{model.body_names[model.pt_body[pt]]}_c{k}")
           for k, pt in enumerate(model.ct_pt)]
    return np.array([i for i in ids if i >= 0], dtype=int)


def vertical_masses(mj, d, geoms: np.ndarray) -> np.ndarray:
    """[len(geoms)] each sphere's effective mass along the vertical at its lowest point, ``1 / (J_z M^-1 J_z^T)``,
    in MuJoCo's current state (its factor of ``M`` from the last step's forward pass)."""
    import mujoco

    J = np.zeros((len(geoms), mj.nv))
    jacp = np.zeros((3, mj.nv))
    for i, g in enumerate(geoms):
        pt = d.geom_xpos[g].copy()
        pt[2] -= mj.geom_size[g, 0]
        mujoco.mj_jac(mj, d, jacp, None, pt, mj.geom_bodyid[g])
        J[i] = jacp[2]
    X = np.zeros_like(J)
    mujoco.mj_solveM(mj, d, X, J)
    return 1.0 / np.maximum(np.einsum("ij,ij->i", J, X), 1e-12)


class PerContact:
    """Eq. 3.7's force per metre for each contact of N robots stepped one after the other on one ``MjModel``:
    :meth:`before` writes robot ``i``'s spheres' ``solref`` into the model, :meth:`after` updates those of the
    spheres that touch from its new state (the others keep theirs)."""

    def __init__(self, mj, geoms: np.ndarray, kb, n: int):
        """``geoms``: the contact spheres; ``kb``: ``(-A, -B)``, eq. 3.7's stiffness and damping (negative, as
        MuJoCo's direct ``solref``); ``n`` robots.  The ground (every other geom that collides) gets the softest
        ``solref``, so that a contact takes its sphere's (MuJoCo gives a contact of two the stiffer)."""
        self.mj = mj
        self.geoms = np.asarray(geoms, int)
        self.kb = np.asarray(kb, float)
        self.solref = np.repeat(mj.geom_solref[self.geoms][None], n, 0)    # [N, n_geoms, 2], as exported
        ground = np.setdiff1d(np.nonzero(mj.geom_conaffinity)[0], self.geoms)
        mj.geom_solref[ground] = -1e-12
        self._slot = {int(g): j for j, g in enumerate(self.geoms)}

    @classmethod
    def of(cls, model, mj, n: int) -> PerContact:
        """For the export of ``model``: its contact spheres, eq. 3.7's ``A`` and ``B`` (times the export's scale)."""
        from cpgjax.crosscheck.mjcf import contact_mass, contact_solref

        k, b = (float(x) for x in contact_solref(model).split())     # -A / m_c, -B / m_c (scaled as exported)
        return cls(mj, contact_geoms(model, mj), np.array([k, b]) * contact_mass(model), n)

    def before(self, i: int) -> None:
        self.mj.geom_solref[self.geoms] = self.solref[i]

    def after(self, i: int, d) -> None:
        touch = sorted({self._slot[g] for g in d.contact.geom[: d.ncon].ravel().tolist() if g in self._slot})
        if touch:
            m = vertical_masses(self.mj, d, self.geoms[touch])
            self.solref[i, touch] = self.kb[None] / m[:, None]


def stepper(model, mj, n: int):
    """``None`` for ``resting``; a :class:`PerContact` for robots ``0..n-1`` under ``per-contact``."""
    return PerContact.of(model, mj, n) if current_law() == "per-contact" else None


def from_rest(model, mj, law: PerContact | None, i: int):
    """A new ``MjData`` of robot ``i`` at the `.wl` initial pose, forward-computed (its touching spheres' ``solref``
    taken under ``law``)."""
    import mujoco

    from cpgjax.crosscheck.mjcf import initial_qpos

    d = mujoco.MjData(mj)
    d.qpos[:] = initial_qpos(model, mj)
    mujoco.mj_forward(mj, d)
    if law is not None:
        law.after(i, d)
    return d


def step(mj, d, law: PerContact | None, i: int) -> None:
    """One MuJoCo step of robot ``i`` under ``law`` (None: the export's contact, unchanged)."""
    import mujoco

    if law is not None:
        law.before(i)
    mujoco.mj_step(mj, d)
    if law is not None:
        law.after(i, d)
