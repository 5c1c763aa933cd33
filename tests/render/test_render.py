"""cpgjax.render: episodes drawn with MuJoCo's renderer (small pictures, short episodes)."""

from __future__ import annotations

import os

import numpy as np
import pytest

from cpgjax.io.ctl import read_ctl
from cpgjax.io.wl import load_model, parse_wl
from cpgjax.render import RenderError, gl, movie, scene, video
from cpgjax.render.movie import episode_frames, initial_poses, open_painter, render_video
from cpgjax.render.poses import distance, record_ours, touching
from cpgjax.sim.model import build_model

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
W, H = 160, 120


def model_path(name):
    return os.path.join(ROOT, "models", name)


@pytest.fixture(scope="module")
def trot():
    m = load_model(model_path("quadruped.wl"))
    c = np.asarray(read_ctl(model_path("quadruped-trot.ctl"), n_dof=m.n_ctrl, harmonics=m.episode.harmonics).coeffs)
    # 6 s at 2 frames a second: the episode of the trot's GIF caption (tests/test_figures.py), one program
    return m, c, record_ours(m, c, time=6.0, fps=2)


def robot_masks(model, poses, camera):
    with open_painter(model, poses, W, H) as p:
        on = list(episode_frames(p, [poses], camera, captions=False))
        off = list(episode_frames(p, [poses], camera, captions=False, robot=False))
    return on, [np.abs(a.astype(int) - b.astype(int)).max(-1) > 24 for a, b in zip(on, off, strict=True)]


def test_recording_is_the_evaluation(trot):
    from cpgjax.episode.batch import simulate

    m, c, poses = trot
    r = simulate(m, c, time=6.0)
    assert poses.frames == 13 and np.allclose(np.diff(poses.t), 0.5)
    assert poses.fitness == pytest.approx(float(r["fitness"]), rel=1e-5, abs=1e-7)
    assert distance(m, poses)[-1] == pytest.approx(float(r["distance"]), abs=1e-5)
    on = touching(m, poses)
    assert on[0].sum() >= 4                  # standing on its feet at t = 0
    assert not on[:, m.pt_body[m.ct_pt] == m.track].any()   # the body plate never touches


def test_robot_is_drawn_and_moves_forward_in_a_side_view(trot):
    m, _, poses = trot
    frames, masks = robot_masks(m, poses, "side")
    assert all(f.shape == (H, W, 3) and f.std() > 5 for f in frames)        # not uniform pictures
    assert all(k.sum() > 50 for k in masks)                                # the robot is in every frame
    cx = np.array([np.nonzero(k)[1].mean() for k in masks])
    walked = distance(m, poses)[-1]
    assert walked > 0.1
    assert cx[-1] - cx[0] > 5               # forward (+y) is to the right in the side view
    assert np.corrcoef(cx, distance(m, poses))[0, 1] > 0.9


def test_track_camera_keeps_the_robot_in_the_picture(trot):
    m, _, poses = trot
    _, masks = robot_masks(m, poses, "track")
    cx = np.array([np.nonzero(k)[1].mean() for k in masks])
    assert all(k.sum() > 100 for k in masks) and np.ptp(cx) < W / 4


# the test reads the MP4 back with imageio's reader, which starts ffmpeg with a preexec_fn (a fork(); cpgjax does not)
@pytest.mark.filterwarnings("ignore:os.fork:RuntimeWarning")
def test_gif_and_mp4_are_written_whole(trot, tmp_path, monkeypatch):
    import imageio.v3 as iio

    m, c, poses = trot
    monkeypatch.setattr(movie, "record_ours", lambda *a, **k: poses)
    s = render_video(m, c, str(tmp_path / "walk.gif"), fps=8, size=(W, H), camera="fixed", progress=False)
    assert s["frames"] == poses.frames and s["episodes"][0]["fitness"] == poses.fitness
    g = iio.imread(tmp_path / "walk.gif", index=None)
    assert g.shape[:3] == (poses.frames, H, W)
    render_video(m, c, str(tmp_path / "walk.mp4"), fps=8, size=(W, H), camera="side", progress=False)
    import imageio.v2

    with imageio.v2.get_reader(tmp_path / "walk.mp4", format="FFMPEG") as r:
        v = [f for f in r]
    assert len(v) == poses.frames and v[0].shape == (H, W, 3)
    assert sorted(os.listdir(tmp_path)) == ["walk.gif", "walk.mp4"]       # no temporary file left


def test_an_mp4_is_encoded_without_a_fork_warning(trot, tmp_path, monkeypatch):
    """ffmpeg is started without running Python in a fork() of this multithreaded process: JAX's "os.fork() was
    called ... deadlock" RuntimeWarning, which a user can do nothing about, is never printed (cpgjax.render.video)."""
    import warnings

    m, c, poses = trot
    monkeypatch.setattr(movie, "record_ours", lambda *a, **k: poses)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        render_video(m, c, str(tmp_path / "walk.mp4"), fps=8, size=(W + 1, H + 1), camera="fixed", progress=False)
    assert [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)] == []
    assert (tmp_path / "walk.mp4").stat().st_size > 1000


def test_an_encoder_failure_is_a_named_error_and_leaves_no_file(tmp_path):
    with pytest.raises(RenderError, match="a frame of shape"), video.VideoWriter(str(tmp_path / "w.mp4"), 8) as w:
        w.append(np.zeros((H, W, 3), np.uint8))
        w.append(np.zeros((H, W + 2, 3), np.uint8))
    assert os.listdir(tmp_path) == []


def test_both_engines_side_by_side(trot, tmp_path, monkeypatch):
    m, c, poses = trot
    monkeypatch.setattr(movie, "record_ours", lambda *a, **k: poses)
    s = render_video(m, c, str(tmp_path / "both.gif"), fps=8, size=(W, H), camera="track", engine="both",
                     progress=False)
    assert s["size"] == (2 * W, H) and [e["engine"] for e in s["episodes"]] == ["ours", "MuJoCo C"]
    ours, mj = s["episodes"]
    assert mj["distance"] > 0.1 and abs(mj["distance"] - ours["distance"]) < 0.5 * ours["distance"]


@pytest.mark.parametrize("out, words", [("walk.avi", "unknown video format"), ("sub", "is a folder"),
                                        ("afile/walk.gif", "is a file, not a folder")])
def test_bad_output_is_a_named_error_and_writes_nothing(trot, tmp_path, out, words):
    m, c, _ = trot
    (tmp_path / "sub").mkdir()
    (tmp_path / "afile").write_text("x")
    before = sorted(os.listdir(tmp_path))
    with pytest.raises(RenderError, match=words):
        render_video(m, c, str(tmp_path / out), time=1.0, size=(W, H), progress=False)
    assert sorted(os.listdir(tmp_path)) == before


def test_missing_gl_backend_is_a_named_error(trot, tmp_path, monkeypatch):
    m, c, _ = trot

    def missing(name):
        raise ImportError(f"lib{name} not found")

    monkeypatch.delenv("MUJOCO_GL", raising=False)
    monkeypatch.setattr(gl, "_context_class", missing)
    with pytest.raises(RenderError, match="no OpenGL back-end.*egl: ImportError.*osmesa: ImportError.*apt-get"):
        render_video(m, c, str(tmp_path / "walk.mp4"), time=1.0, size=(W, H), progress=False)
    assert os.listdir(tmp_path) == []


def test_missing_encoder_is_a_named_error(tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)        # import fails
    with pytest.raises(RenderError, match="no MP4 encoder.*pip install imageio imageio-ffmpeg"):
        video.check_output(str(tmp_path / "walk.mp4"))
    video.check_output(str(tmp_path / "walk.gif"))                   # GIF needs only Pillow


def test_failure_while_drawing_leaves_no_file(trot, tmp_path, monkeypatch):
    m, c, poses = trot
    monkeypatch.setattr(movie, "record_ours", lambda *a, **k: poses)
    calls = []

    def broken(self, *a, **k):
        calls.append(1)
        if len(calls) > 3:
            raise RuntimeError("GL context lost")
        return np.zeros((H, W, 3), np.uint8)

    monkeypatch.setattr(scene.Painter, "frame", broken)
    (tmp_path / "walk.gif").write_bytes(b"old")
    with pytest.raises(RuntimeError, match="GL context lost"):
        render_video(m, c, str(tmp_path / "walk.gif"), fps=8, size=(W, H), progress=False)
    assert os.listdir(tmp_path) == ["walk.gif"] and (tmp_path / "walk.gif").read_bytes() == b"old"


ALL_SHAPES = """
ColorDef Red 1 0 0
ColorDef Blue 0 0 1
TimeMax 1
Object Plate {
    Type Cube
    Color Red
    Mass 1
    Dimensions .3 .2 .04
}
Object Ball {
    Type Sphere
    Color Blue
    Mass .2
    Dimensions .05
    Position .1 0 .05
}
Object Axle {
    Type Cylinder
    Mass .1
    Dimensions .02 .3
    Position 0 .08 0
    Orientation 0 0 .3
}
Compound Cart {
    Plate Ball Axle
    Position 0 0 .2
}
Object Wheel {
    Type Cylinder
    Color Blue
    Mass .1
    Dimensions .05 .02
}
Object Loose {
    Type Sphere
    Mass .1
    Dimensions .03
    Position .5 0 .03
}
Joint Hub {
    Cart 0 -.1 0
    Wheel 0 0 0
    PassiveX
}
"""


def test_every_body_type_is_drawn_in_its_colour():
    import mujoco

    m = build_model(parse_wl(ALL_SHAPES, "shapes.wl"))
    mj = mujoco.MjModel.from_xml_string(scene.scene_xml(m, W, H))
    robot = mj.geom_group == 1
    types = [mujoco.mjtGeom(t).name for t in mj.geom_type[robot]]
    assert sorted(types) == sorted(["mjGEOM_BOX", "mjGEOM_SPHERE", "mjGEOM_CYLINDER", "mjGEOM_CYLINDER",
                                    "mjGEOM_SPHERE"])
    rgba = {mj.geom(i).name: tuple(mj.geom_rgba[i]) for i in np.nonzero(robot)[0]}
    assert rgba["g_Plate"] == (1, 0, 0, 1) and rgba["g_Ball"] == (0, 0, 1, 1)
    assert rgba["g_Axle"] == pytest.approx(scene.DEFAULT_RGBA)
    # the axle's cylinder lies along its object's x axis (turned by its compound Orientation)
    from cpgjax.render.poses import rotations

    axle = next(s for s in scene.shapes(m) if s.name == "Axle")
    z = rotations(np.asarray(axle.quat))[:, 2]
    assert z == pytest.approx([np.cos(.3), np.sin(.3), 0], abs=1e-6)
    p = initial_poses(m)
    _, masks = robot_masks(m, p, "fixed")
    assert masks[0].sum() > 100


@pytest.mark.parametrize("name", ["quadruped", "hexapod", "worm", "car"])
def test_example_robots_have_a_scene(name):
    m = load_model(model_path(f"{name}.wl"))
    p = initial_poses(m)
    frames, masks = robot_masks(m, p, "track")
    assert masks[0].sum() > 200, name


def test_a_run_files_best_renders_through_the_command_line(tiny_runs, tmp_path, capsys):
    """``cpgjax render RUN.h5 [--generation G]``: the run's best (of that generation) on the run's own model."""
    from cpgjax import cli

    run = tiny_runs["thesis"]
    out = tmp_path / "best.gif"
    # 6 s at 2 frames a second: the recording program of the ``trot`` fixture
    assert cli.main(["render", run, "--generation", "1", "--time", "6", "--fps", "2", "--size", "80x60",
                     "--camera", "fixed", "--out", str(out), "--quiet"]) == 0
    assert out.stat().st_size > 1000 and "fitness" in capsys.readouterr().out
    assert cli.main(["render", run, "--generation", "5", "--out", str(tmp_path / "x.gif")]) == 2
    assert "generations 0..1" in capsys.readouterr().err and not (tmp_path / "x.gif").exists()



def test_a_paths_waypoints_are_drawn_green_once_passed_and_counted_in_the_caption(trot):
    """follow's videos: the waypoints as discs on the ground (orange, green once passed), "waypoints k of n" in the
    caption only where the count is known, and no fitness line for a walk (its fitness NaN)."""
    import dataclasses

    m, _, poses = trot
    walk = dataclasses.replace(poses, fitness=float("nan"))
    pts = np.array([[0.0, 0.3], [0.0, 0.6]])
    with open_painter(m, walk, W, H) as p:
        plain = next(episode_frames(p, [walk], "fixed", captions=False))
        ahead = next(episode_frames(p, [walk], "fixed", captions=False, waypoints=pts, passed=np.zeros(13)))
        done = next(episode_frames(p, [walk], "fixed", captions=False, waypoints=pts, passed=np.full(13, 2)))
        said = []
        frame = p.frame
        p.frame = lambda *a, caption=None, **k: said.append(caption) or frame(*a, caption=caption, **k)
        list(episode_frames(p, [walk], "fixed", waypoints=pts, passed=np.arange(13) // 6))
        list(episode_frames(p, [walk], "fixed", waypoints=pts))
    drawn = np.abs(ahead.astype(int) - plain.astype(int)).max(-1) > 24
    assert drawn.sum() > 10                                       # the discs are in the picture
    orange, green = ahead[drawn].astype(int).mean(0), done[drawn].astype(int).mean(0)
    assert orange[0] > orange[1] and green[1] > green[0]          # orange ahead, green once passed
    assert [c[-1] for c in said[:13]] == [f"waypoints {k // 6} of 2" for k in range(13)]
    assert all(not c[-1].startswith("waypoints") for c in said[13:])          # not known: not said
    assert not any(line.startswith("fitness") for c in said for line in c)     # a walk has no fitness
    assert movie.caption(poses, 0, np.zeros(13), 0.1)[-1].startswith("fitness ")   # an episode has one
