"""Encoding frames to MP4 (H.264, imageio-ffmpeg's own ffmpeg) or GIF (imageio's Pillow plugin), never half-written.

:func:`check_output` is called before any work (a bad path fails in a second, not after the
episode); :class:`VideoWriter` writes into a temporary file beside the output (``.NAME.XXXX.EXT``)
and renames it onto the output only when every frame is in, so that an error or a Ctrl-C leaves
the old file (or none) and no partial one.
"""

from __future__ import annotations

import os
import tempfile

import numpy as np

from cpgjax.io.paths import first_existing
from cpgjax.render import RenderError

FORMATS = (".mp4", ".gif")


def video_format(path: str) -> str:
    """The format of an output path from its extension: ``.mp4`` or ``.gif``."""
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext not in FORMATS:
        raise RenderError(f"{path}: unknown video format {ext or '(no extension)'!r}: name a .mp4 or .gif file")
    return ext


def check_output(path: str) -> str:
    """Raise :class:`RenderError` (naming ``path``) if the video cannot be written there; returns its format.

    Creates nothing.  A missing folder is fine if it can be created.
    """
    p = os.fspath(path)
    if os.path.isdir(p):
        raise RenderError(f"{p}: is a folder; --out needs a file name (e.g. {os.path.join(p, 'walk.mp4')})")
    fmt = video_format(p)
    if os.path.lexists(p) and not os.access(p, os.W_OK):
        raise RenderError(f"{p}: cannot write: permission denied")
    anc = first_existing(os.path.dirname(p))
    if not os.path.isdir(anc):
        raise RenderError(f"{p}: cannot write there: {anc} is a file, not a folder")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise RenderError(f"{p}: cannot write there: the folder {anc} is not writable")
    check_encoder(fmt)
    return fmt


def check_encoder(fmt: str) -> None:
    """Raise :class:`RenderError` when the encoder of ``fmt`` is not installed."""
    try:
        import imageio  # noqa: F401
        if fmt == ".mp4":
            import imageio_ffmpeg

            imageio_ffmpeg.get_ffmpeg_exe()
        else:
            import PIL  # noqa: F401
    except (ImportError, RuntimeError, OSError) as e:
        pkg = "imageio imageio-ffmpeg" if fmt == ".mp4" else "imageio pillow"
        raise RenderError(f"no {fmt[1:].upper()} encoder ({type(e).__name__}: {e}); install it: "
                          f"pip install {pkg} (pinned in pyproject.toml)") from None


class VideoWriter:
    """``with VideoWriter(path, fps) as w: w.append(frame)``: the file appears, whole, when the block ends."""

    def __init__(self, path: str, fps: float):
        self.path = os.fspath(path)
        self.fmt = check_output(self.path)
        self.fps = float(fps)
        self.frames = 0
        self._tmp: str | None = None
        self._writer = None
        self._gif: list[np.ndarray] = []

    def __enter__(self) -> VideoWriter:
        folder = os.path.dirname(os.path.abspath(self.path))
        try:
            os.makedirs(folder, exist_ok=True)
            fd, self._tmp = tempfile.mkstemp(dir=folder, prefix=f".{os.path.basename(self.path)}.",
                                             suffix=self.fmt)
            os.close(fd)
        except OSError as e:
            raise RenderError(f"{self.path}: cannot write there: {e.strerror or e}") from None
        if self.fmt == ".mp4":
            import imageio.v2 as iio

            self._writer = iio.get_writer(self._tmp, format="FFMPEG", mode="I", fps=self.fps, codec="libx264",
                                          quality=7, pixelformat="yuv420p", macro_block_size=2,
                                          ffmpeg_log_level="error")
        return self

    def append(self, frame: np.ndarray) -> None:
        frame = np.ascontiguousarray(frame, np.uint8)
        if self._writer is not None:
            self._writer.append_data(frame)
        else:
            self._gif.append(frame)
        self.frames += 1

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if self._writer is not None:
                self._writer.close()
            if exc_type is None:
                if self.frames == 0:
                    raise RenderError(f"{self.path}: no frames to write")
                if self.fmt == ".gif":
                    import imageio.v3 as iio

                    iio.imwrite(self._tmp, np.stack(self._gif), extension=".gif", plugin="pillow",
                                duration=round(1000.0 / self.fps), loop=0)
                mask = os.umask(0)
                os.umask(mask)
                os.chmod(self._tmp, 0o666 & ~mask)      # mkstemp made it private
                os.replace(self._tmp, self.path)
                self._tmp = None
        finally:
            self._gif = []
            if self._tmp is not None and os.path.exists(self._tmp):
                os.remove(self._tmp)
