"""Encoding frames to MP4 (H.264, imageio-ffmpeg's own ffmpeg) or GIF (imageio's Pillow plugin), never half-written.

:func:`check_output` is called before any work (a bad path fails in a second, not after the
episode); :class:`VideoWriter` writes into a temporary file beside the output (``.NAME.XXXX.EXT``)
and renames it onto the output only when every frame is in, so that an error or a Ctrl-C leaves
the old file (or none) and no partial one.

MP4: :class:`H264Pipe` feeds raw frames to imageio-ffmpeg's ffmpeg binary on its stdin, started by
:mod:`subprocess` with no Python code to run in the child.  imageio's own FFMPEG writer starts ffmpeg with
``preexec_fn=os.setpgrp``, which makes CPython ``fork()`` the whole process and run Python in the child; in a
process where JAX's thread pools run, that can deadlock, and JAX says so on every render (``RuntimeWarning:
os.fork() was called ...``).  ``start_new_session=True`` does what ``os.setpgrp`` did for imageio (ffmpeg out
of the terminal's process group: a Ctrl-C reaches cpgjax alone, which then stops ffmpeg and removes the
temporary file) inside the child's C code, so the child is spawned without running Python and JAX's
fork handlers.
"""

from __future__ import annotations

import os
import subprocess
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


class H264Pipe:
    """Frames [H, W, 3] uint8 to an H.264 MP4 at ``path`` (yuv420p, constant quality), through ffmpeg's stdin.

    The encoder's settings are those of imageio's FFMPEG writer at ``quality=7`` (CRF 15) with
    ``macro_block_size=2`` (an odd width or height is scaled up to the next even one, as yuv420p needs).
    """

    CRF = 15

    def __init__(self, path: str, fps: float):
        self.path, self.fps = os.fspath(path), float(fps)
        self._proc: subprocess.Popen | None = None
        self._shape: tuple[int, ...] | None = None

    def _start(self, shape: tuple[int, ...]) -> None:
        from fractions import Fraction

        import imageio_ffmpeg

        h, w = shape[:2]
        cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-f", "rawvideo", "-vcodec", "rawvideo", "-s", f"{w}x{h}",
               "-pix_fmt", "rgb24", "-r", str(Fraction(self.fps).limit_denominator()), "-i", "-", "-an",
               "-vcodec", "libx264", "-pix_fmt", "yuv420p", "-crf", str(self.CRF)]
        if w % 2 or h % 2:
            cmd += ["-vf", f"scale={w + w % 2}:{h + h % 2}"]
        cmd += ["-v", "error", self.path]
        # no preexec_fn: the child runs no Python, so no fork() of this multithreaded process (module docstring)
        self._proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                      start_new_session=True)
        self._shape = shape

    def append(self, frame: np.ndarray) -> None:
        if frame.ndim != 3 or frame.shape[2] != 3 or frame.shape != (self._shape or frame.shape):
            raise RenderError(f"{self.path}: a frame of shape {frame.shape}, expected {self._shape or '(H, W, 3)'}")
        if self._proc is None:
            self._start(frame.shape)
        try:
            self._proc.stdin.write(frame.tobytes())
        except OSError as e:                        # ffmpeg exited (its own message is on stderr)
            raise RenderError(f"{self.path}: the H.264 encoder (ffmpeg) stopped: {e}") from None

    def close(self, ok: bool = True) -> None:
        """Finish the file (``ok``) or stop ffmpeg at once (an error or a Ctrl-C: the file is discarded)."""
        p, self._proc = self._proc, None
        if p is None:
            return
        if not ok:
            p.kill()
        try:
            p.stdin.close()
        except OSError:
            pass
        code = p.wait()
        if ok and code != 0:
            raise RenderError(f"{self.path}: the H.264 encoder (ffmpeg) failed, exit code {code}")


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
            self._writer = H264Pipe(self._tmp, self.fps)
        return self

    def append(self, frame: np.ndarray) -> None:
        frame = np.ascontiguousarray(frame, np.uint8)
        if self._writer is not None:
            self._writer.append(frame)
        else:
            self._gif.append(frame)
        self.frames += 1

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if self._writer is not None:
                self._writer.close(ok=exc_type is None)
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
