"""The OpenGL back-end of off-screen rendering: EGL (Mesa's software renderer on a CPU-only machine), else OSMesa.

MuJoCo picks its GL back-end once, when ``mujoco`` is first imported, from the ``MUJOCO_GL``
environment variable (unset on Linux means GLFW, which needs a display).  :func:`open_renderer`
does not depend on who imported ``mujoco`` first (a test, a notebook): it tries the back-ends of
:data:`BACKENDS` in turn (only the one ``MUJOCO_GL`` names, when it is set) and hands the one that
works to ``mujoco.Renderer``.  When none works it raises :class:`~cpgjax.render.RenderError`
naming what each said and the Debian packages that provide them.
"""

from __future__ import annotations

import os

from cpgjax.render import RenderError

BACKENDS = ("egl", "osmesa")
#: Debian / Ubuntu packages that provide the back-ends (what `make setup` installs).
APT_PACKAGES = {"egl": "libegl1 libgl1 libgles2 libegl-mesa0 libgl1-mesa-dri", "osmesa": "libosmesa6"}


def _context_class(name: str):
    """The ``GLContext`` class of MuJoCo's back-end ``name`` (ImportError / OSError when it is missing)."""
    if name == "egl":
        from mujoco.egl import GLContext
    elif name == "osmesa":
        from mujoco.osmesa import GLContext
    elif name == "glfw":
        from mujoco.glfw import GLContext
    else:
        raise ImportError(f"unknown back-end {name!r} (MUJOCO_GL): use egl or osmesa")
    return GLContext


def candidates() -> tuple[str, ...]:
    """The back-ends to try: the one ``MUJOCO_GL`` names, else :data:`BACKENDS`."""
    env = os.environ.get("MUJOCO_GL", "").strip().lower()
    return (env,) if env else BACKENDS


def open_renderer(mj, height: int, width: int):
    """A ``mujoco.Renderer`` of ``mj`` (``height`` x ``width`` pixels) on the first back-end that works.

    Returns (renderer, back-end name).  Raises :class:`RenderError` when none works.
    """
    names = candidates()
    os.environ.setdefault("MUJOCO_GL", names[0])   # for a first import of mujoco from here on
    import mujoco
    from mujoco.rendering.classic import gl_context

    tried = []
    for name in names:
        try:
            cls = _context_class(name)
        except Exception as e:  # ImportError, OSError (a library missing), AttributeError (PyOpenGL)
            tried.append(f"{name}: {type(e).__name__}: {e}")
            continue
        old = getattr(gl_context, "GLContext", None)
        gl_context.GLContext = cls
        try:
            r = mujoco.Renderer(mj, height, width)
        except Exception as e:  # the library is there but no context could be made
            tried.append(f"{name}: {type(e).__name__}: {e}")
            gl_context.GLContext = old
            continue
        return r, name
    pkgs = " ".join(APT_PACKAGES.values())
    raise RenderError("no OpenGL back-end for off-screen rendering (" + "; ".join(tried) + "); install EGL or "
                      f"OSMesa (Debian/Ubuntu: apt-get install -y {pkgs}) or set MUJOCO_GL to one that works")
