"""A replay scene generated from a model, its cameras, and one drawn frame.

The scene is MJCF written here (not the physics export of :mod:`cpgjax.crosscheck.mjcf`): every body
of the model is a *mocap* body of the world (no joints, no physics) holding its objects as visual
geoms: a ``Cube`` is a box, a ``Cylinder`` a cylinder (its axis along the object's local x, as in
the `.wl` format), a ``Sphere`` a sphere, each at its place in its compound and in its ``ColorDef``
colour (grey without one).  A frame sets each mocap body to the recorded body frame, runs
``mj_kinematics`` (and ``mj_camlight``) and renders with ``mujoco.Renderer``.  The ground is a checkered plane (flat) or
the terrain's own heightfield (bumps, roughness, ramps, matrices: the heights our simulator uses);
its squares are :func:`checker` metres, to read distances by.  The contact vertices that touch the
terrain are red dots, and a caption gives the time, the distance walked and the episode's fitness.

Geom groups: 0 the ground, 1 the robot (hide it with ``robot=False``: the tests compare).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from cpgjax.crosscheck.ground import course_ground, ledge_boxes
from cpgjax.render.poses import Poses, contact_points, rotations, touching
from cpgjax.sim.course import rough_spans
from cpgjax.sim.rotation import euler_to_mat, mat_to_quat

CAMERAS = ("track", "fixed", "side")
DEFAULT_RGBA = (0.6, 0.6, 0.62, 1.0)
CONTACT_RGBA = (0.9, 0.1, 0.1, 1.0)
WAYPOINT_RGBA = (1.0, 0.55, 0.0, 1.0)      # a path's waypoint still to pass (follow's videos) ...
PASSED_RGBA = (0.1, 0.7, 0.2, 1.0)         # ... and one passed
FOVY = 45.0  # degrees
VIEW = {"track": (145.0, -20.0), "fixed": (145.0, -25.0), "side": (180.0, -12.0)}  # azimuth, elevation (deg)
_CELLS = (0.01, 0.02, 0.05, 0.1, 0.2, 0.25, 0.5, 1.0, 2.0, 5.0)


@dataclass(frozen=True)
class Shape:
    """One object drawn on a body: MuJoCo geom type and size, its pose in the body frame, its colour."""

    body: int
    name: str
    type: str          # box | cylinder | sphere
    size: tuple[float, ...]
    pos: tuple[float, float, float]
    quat: tuple[float, float, float, float]
    rgba: tuple[float, float, float, float]
    radius: float      # of a sphere around it (for framing)


def shapes(model) -> list[Shape]:
    """Every object of the model's description as a geom on its body."""
    desc = model.description
    if desc is None:
        raise ValueError("the model has no description (.wl): nothing to draw")
    out = []
    for b, name in enumerate(model.body_names):
        inside = name in desc.compounds
        for m in desc.compounds[name].objects if inside else (name,):
            o = desc.objects[m]
            R = euler_to_mat(*o.orientation) if inside else np.eye(3)
            pos = tuple(float(v) for v in (o.position if inside else (0.0, 0.0, 0.0)))
            c = desc.colors.get(o.color) if o.color else None
            rgba = (*map(float, c), 1.0) if c is not None else DEFAULT_RGBA
            t = o.type.lower()
            if t == "cube":
                size = tuple(float(v) / 2 for v in o.dimensions)
                kind, radius = "box", float(np.linalg.norm(size))
            elif t == "cylinder":
                r, length = (float(v) for v in o.dimensions)
                size, kind, radius = (r, length / 2), "cylinder", math.hypot(r, length / 2)
                R = R @ euler_to_mat(0.0, math.pi / 2, 0.0)     # MuJoCo's cylinder axis is z; ours is x
            else:
                size, kind, radius = (float(o.dimensions[0]),), "sphere", float(o.dimensions[0])
            quat = tuple(float(v) for v in mat_to_quat(R))
            out.append(Shape(b, m, kind, size, pos, quat, rgba, radius))
    return out


def _f(v) -> str:
    return " ".join(f"{float(x):.9g}" for x in np.ravel(v))


def extent(model, poses: Poses, frame: int = 0) -> float:
    """The robot's size (m): the largest side of the box around its objects at ``frame``."""
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    R = rotations(poses.quat[frame])
    for s in shapes(model):
        c = poses.pos[frame, s.body] + R[s.body] @ np.asarray(s.pos)
        lo, hi = np.minimum(lo, c - s.radius), np.maximum(hi, c + s.radius)
    return float(max(np.max(hi - lo), 1e-3))


def checker(size: float) -> float:
    """The ground's squares (m) for a robot of ``size``: a round number, about a quarter of it."""
    fits = [c for c in _CELLS if c <= size / 4]
    return fits[-1] if fits else _CELLS[0]


def scene_xml(model, width: int, height: int, *, cell: float = 0.1) -> str:
    """MJCF of the replay scene (see the module docstring)."""
    root = ET.Element("mujoco", model="cpgjax-replay")
    ET.SubElement(root, "compiler", angle="radian")
    vis = ET.SubElement(root, "visual")
    ET.SubElement(vis, "global", offwidth=str(width), offheight=str(height), fovy=f"{FOVY:g}")
    ET.SubElement(vis, "headlight", ambient=".3 .3 .3", diffuse=".3 .3 .3", specular=".05 .05 .05")
    ET.SubElement(vis, "map", znear="0.005", zfar="200")
    asset = ET.SubElement(root, "asset")
    ET.SubElement(asset, "texture", name="sky", type="skybox", builtin="gradient", rgb1=".62 .76 .90",
                  rgb2=".95 .97 1", width="32", height="192")
    ET.SubElement(asset, "texture", name="grid", type="2d", builtin="checker", rgb1=".80 .80 .78",
                  rgb2=".64 .64 .62", width="256", height="256")
    rep = 1.0 / (2.0 * cell)    # the texture is 2 x 2 squares; texuniform: repeats per metre
    ET.SubElement(asset, "material", name="ground", texture="grid", texuniform="true", texrepeat=f"{rep:g} {rep:g}",
                  reflectance="0", specular="0.1")
    world = ET.SubElement(root, "worldbody")
    ET.SubElement(world, "light", name="sun", directional="true", pos="0 0 10", dir="-.45 .35 -1",
                  diffuse=".55 .55 .55", specular=".1 .1 .1", castshadow="false")
    t = model.terrain
    if t.flat:
        ET.SubElement(world, "geom", name="ground", type="plane", size="0 0 0.05", material="ground", group="0",
                      contype="0", conaffinity="0")
    elif t.ledges is not None:             # ledges (and a course's rough items): the export's, not lowered
        looks = dict(material="ground", group="0", contype="0", conaffinity="0")
        if t.heights is None:
            ledge_boxes(world, t.ledges, radius=0.0, attrs=looks)
        else:
            course_ground(asset, world, t, rough_spans(t.spec), radius=0.0, attrs=looks)
    else:
        ny, nx = t.heights.shape
        hmin, hmax = float(t.heights.min()), float(t.heights.max())
        span = max(hmax - hmin, 1e-6)
        base = max(0.05, 0.1 * span)
        ET.SubElement(asset, "hfield", name="terrain", nrow=str(ny), ncol=str(nx),
                      size=f"{t.dx * (nx - 1) / 2:g} {t.dy * (ny - 1) / 2:g} {span:g} {base:g}",
                      elevation=_f(((t.heights - hmin) / span)[::-1]))   # MuJoCo's first row is at +y
        cx, cy = t.x0 + t.dx * (nx - 1) / 2, t.y0 + t.dy * (ny - 1) / 2
        ET.SubElement(world, "geom", name="ground", type="hfield", hfield="terrain", pos=f"{cx:g} {cy:g} {hmin:g}",
                      material="ground", group="0", contype="0", conaffinity="0")
        # beyond the grid our terrain keeps the height of its nearest edge: a plane there (just below it)
        edges = np.concatenate([t.heights[0], t.heights[-1], t.heights[:, 0], t.heights[:, -1]])
        z = float(edges[0]) if np.ptp(edges) < 1e-9 else hmin - base
        ET.SubElement(world, "geom", name="beyond", type="plane", size="0 0 0.05", pos=f"0 0 {z - 5e-4:g}",
                      material="ground", group="0", contype="0", conaffinity="0")
    bodies = {}
    for b, name in enumerate(model.body_names):
        bodies[b] = ET.SubElement(world, "body", name=f"b{b}_{name}", mocap="true")
    for s in shapes(model):
        ET.SubElement(bodies[s.body], "geom", name=f"g_{s.name}", type=s.type, size=_f(s.size), pos=_f(s.pos),
                      quat=_f(s.quat), rgba=_f(s.rgba), group="1", contype="0", conaffinity="0", mass="0")
    ET.indent(root)
    return ET.tostring(root, encoding="unicode")


@dataclass
class View:
    """A free camera: where it looks, from how far, from which side."""

    lookat: np.ndarray
    distance: float
    azimuth: float
    elevation: float


def _axes(azimuth: float, elevation: float):
    a, e = math.radians(azimuth), math.radians(elevation)
    fwd = np.array([math.cos(a) * math.cos(e), math.sin(a) * math.cos(e), math.sin(e)])
    right = np.array([math.sin(a), -math.cos(a), 0.0])
    up = np.cross(right, fwd)
    return fwd, right, up


def _fit(points: np.ndarray, azimuth: float, elevation: float, margin: float, aspect: float):
    """(lookat, distance) that frames ``points`` [n, 3] (each padded by ``margin``) from this side."""
    fwd, right, up = _axes(azimuth, elevation)
    lo, hi = points.min(0), points.max(0)
    centre = (lo + hi) / 2
    d = points - centre
    hw = np.abs(d @ right).max() + margin
    hh = np.abs(d @ up).max() + margin
    depth = np.abs(d @ fwd).max() + margin
    ty = math.tan(math.radians(FOVY) / 2)
    tx = ty * aspect
    return centre, 1.1 * max(hw / tx, hh / ty) + depth


def views(model, poses: list[Poses], mode: str, aspect: float, size: float) -> list[list[View]]:
    """One view per frame of each episode of ``poses``.

    ``track``: follows the tracked body (its CM averaged over half a second: the gait's bobbing does
    not shake the picture) from behind and to the right; ``fixed``: one view from the same side that
    holds the whole path of every episode; ``side``: one view from the right (+x), forward (+y) to
    the right of the picture, holding the whole path.
    """
    from cpgjax.render.poses import cm_positions

    if mode not in CAMERAS:
        raise ValueError(f"camera {mode!r}: expected one of {', '.join(CAMERAS)}")
    az, el = VIEW[mode]
    cms = [cm_positions(model, p) for p in poses]
    if mode == "track":
        out = []
        for p, cm in zip(poses, cms, strict=True):
            dt = float(np.median(np.diff(p.t))) if p.frames > 1 else 1.0
            w = max(1, int(round(0.5 / dt)))
            c = cm[:, model.track]
            k = np.ones(w) / w
            pad = np.concatenate([np.repeat(c[:1], w // 2, 0), c, np.repeat(c[-1:], w - 1 - w // 2, 0)])
            smooth = np.stack([np.convolve(pad[:, i], k, mode="valid") for i in range(3)], 1)
            look, dist = _fit(np.stack([c[0] - size / 2, c[0] + size / 2]), az, el, 0.25 * size, aspect)
            out.append([View(smooth[f], dist, az, el) for f in range(p.frames)])
        return out
    pts = np.concatenate([cm.reshape(-1, 3) for cm in cms])
    look, dist = _fit(pts, az, el, 0.6 * size, aspect)
    return [[View(look, dist, az, el)] * p.frames for p in poses]


class Painter:
    """Draws frames of one model's episodes: a replay scene and a ``mujoco.Renderer`` (see the module docstring)."""

    def __init__(self, model, width: int, height: int, *, cell: float = 0.1, marker: float = 0.006):
        import mujoco

        from cpgjax.render.gl import open_renderer

        self.model, self.width, self.height, self.marker, self.cell = model, width, height, marker, cell
        self.mj = mujoco.MjModel.from_xml_string(scene_xml(model, width, height, cell=cell))
        self.data = mujoco.MjData(self.mj)
        body = mujoco.mjtObj.mjOBJ_BODY
        ids = [mujoco.mj_name2id(self.mj, body, f"b{b}_{n}") for b, n in enumerate(model.body_names)]
        self.mocap = np.asarray([self.mj.body_mocapid[i] for i in ids])
        self.renderer, self.backend = open_renderer(self.mj, height, width)
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self.option = mujoco.MjvOption()
        self._points: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def close(self) -> None:
        self.renderer.close()

    def __enter__(self) -> Painter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _contacts(self, poses: Poses):
        key = id(poses)
        if key not in self._points:
            p = contact_points(self.model, poses)
            self._points[key] = (p, touching(self.model, poses, p))
        return self._points[key]

    def frame(self, poses: Poses, k: int, view: View, *, caption: list[str] | None = None, robot: bool = True,
              markers: bool = True, waypoints: np.ndarray | None = None, passed: int = 0) -> np.ndarray:
        """Frame ``k`` of ``poses`` as uint8 [height, width, 3]; ``waypoints`` [n, 2] (m, on flat ground): a path's
        waypoints drawn as discs on the ground, the first ``passed`` of them in green."""
        import mujoco

        d = self.data
        d.mocap_pos[self.mocap] = poses.pos[k]
        d.mocap_quat[self.mocap] = poses.quat[k]
        mujoco.mj_kinematics(self.mj, d)
        mujoco.mj_camlight(self.mj, d)      # the lights' world frames (mj_kinematics leaves them out)
        cam = self.camera
        cam.lookat[:] = view.lookat
        cam.distance, cam.azimuth, cam.elevation = view.distance, view.azimuth, view.elevation
        self.option.geomgroup[1] = 1 if robot else 0
        self.renderer.update_scene(d, camera=cam, scene_option=self.option)
        if markers and robot:
            pts, on = self._contacts(poses)
            scn = self.renderer.scene
            for p in pts[k][on[k]]:
                if scn.ngeom >= scn.maxgeom:
                    break
                mujoco.mjv_initGeom(scn.geoms[scn.ngeom], mujoco.mjtGeom.mjGEOM_SPHERE, np.array([self.marker, 0, 0]),
                                    p, np.eye(3).ravel(), np.asarray(CONTACT_RGBA, np.float32))
                scn.ngeom += 1
        scn = self.renderer.scene
        for i, xy in enumerate(() if waypoints is None else waypoints):
            if scn.ngeom >= scn.maxgeom:
                break
            r = 4 * self.marker
            mujoco.mjv_initGeom(scn.geoms[scn.ngeom], mujoco.mjtGeom.mjGEOM_CYLINDER, np.array([r, r, 0.1 * r]),
                                np.array([xy[0], xy[1], 0.1 * r]), np.eye(3).ravel(),
                                np.asarray(PASSED_RGBA if i < passed else WAYPOINT_RGBA, np.float32))
            scn.ngeom += 1
        img = self.renderer.render().copy()
        if caption:
            img = draw_caption(img, caption)
        return img


def draw_caption(img: np.ndarray, lines: list[str]) -> np.ndarray:
    """The lines of text on a dark band at the top of the picture."""
    from PIL import Image, ImageDraw, ImageFont

    h, w = img.shape[:2]
    size = max(8, min(h // 26, w // 45))
    font = ImageFont.load_default(size=size)
    pic = Image.fromarray(img)
    draw = ImageDraw.Draw(pic, "RGBA")
    pad = max(2, size // 3)
    band = pad + len(lines) * (size + pad)
    draw.rectangle([0, 0, w, band], fill=(0, 0, 0, 140))
    for i, line in enumerate(lines):
        draw.text((pad + 1, pad + i * (size + pad)), line, fill=(255, 255, 255, 255), font=font)
    return np.asarray(pic)
