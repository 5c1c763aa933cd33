"""Episodes drawn frame by frame with MuJoCo's renderer and encoded to MP4 / GIF.

Rendering is a separate step on a *recorded* trajectory, never part of an evaluation:

- :mod:`~cpgjax.render.poses`: what is drawn, frame by frame (:class:`~cpgjax.render.poses.Poses`):
  the body poses of one episode of our simulator (recorded by :func:`cpgjax.episode.rollout.rollout`
  at the video's frame rate), of the same controller in MuJoCo C, or of a run's best genome;
- :mod:`~cpgjax.render.scene`: a replay scene generated from the model (one mocap body per body, its
  objects as boxes / cylinders / spheres in their ``ColorDef`` colours, the terrain as a plane or a
  heightfield), a camera (``track`` / ``fixed`` / ``side``), the feet in contact marked and a caption;
- :mod:`~cpgjax.render.gl`: the OpenGL back-end for off-screen rendering (EGL, else OSMesa);
- :mod:`~cpgjax.render.video`: the encoders (imageio + imageio-ffmpeg), written to a temporary file in the
  output's folder and renamed at the end, so that nothing is ever half-written;
- :mod:`~cpgjax.render.movie`: :func:`~cpgjax.render.movie.render_video`, the whole thing.

docs/render.md has the commands.
"""

from __future__ import annotations

from cpgjax.errors import CpgjaxError


class RenderError(CpgjaxError):
    """A video that cannot be made as asked: no GL back-end, no encoder, an output that cannot be written."""
