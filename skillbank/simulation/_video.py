"""Off-screen rendering of a simulation to an animated GIF (mujoco.Renderer, Pillow).

MuJoCo picks its OpenGL backend when it is first imported, from ``MUJOCO_GL``.
:func:`select_gl` sets it, before that import, to the first backend that
renders here (EGL, then OSMesa), each tried in a child process so that a
backend that crashes cannot take this one with it.
"""

from __future__ import annotations

import io
import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np

__all__ = ["select_gl", "check_video_path", "Recorder", "NO_GL"]

#: What a user without a working OpenGL backend reads.
NO_GL = ("video: no OpenGL backend renders off-screen here (tried MUJOCO_GL=egl and osmesa); install Mesa's "
         "EGL (apt-get install libegl1 libgl1-mesa-dri) or OSMesa (apt-get install libosmesa6), or leave out "
         "--video")

_PROBE = ("import mujoco\n"
          "xml = '<mujoco><worldbody><geom size=\"0.1\"/></worldbody></mujoco>'\n"
          "m = mujoco.MjModel.from_xml_string(xml)\n"
          "r = mujoco.Renderer(m, 16, 16)\n"
          "d = mujoco.MjData(m)\n"
          "r.update_scene(d)\n"
          "r.render()\n"
          "r.close()\n")


def _works(backend: str) -> bool:
    env = dict(os.environ, MUJOCO_GL=backend)
    env.pop("PYOPENGL_PLATFORM", None)
    try:
        done = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return done.returncode == 0


def select_gl() -> str:
    """The OpenGL backend MuJoCo will use: ``MUJOCO_GL`` as set, or the first of egl, osmesa that works.

    Raises ValueError (:data:`NO_GL`) when none does. Once MuJoCo is imported its choice is fixed, so a
    process that imported it without ``MUJOCO_GL`` keeps its default (GLFW, which needs a display).
    """
    if os.environ.get("MUJOCO_GL"):
        return os.environ["MUJOCO_GL"]
    if "mujoco" in sys.modules:
        return ""
    for backend in ("egl", "osmesa"):
        if _works(backend):
            os.environ["MUJOCO_GL"] = backend
            return backend
    raise ValueError(NO_GL)


def check_video_path(path) -> Path:
    """A ``.gif`` in an existing folder (Pillow writes animated GIF; no MP4 writer is a dependency)."""
    path = Path(path)
    if path.suffix.lower() != ".gif":
        raise ValueError(f"video: expected a .gif file (an animated GIF, written with Pillow), got "
                         f"{str(path)!r}")
    if not path.parent.is_dir():
        raise ValueError(f"video: expected a file in an existing folder, got {str(path)!r}")
    return path


def _gif_header(width: int, height: int) -> bytes:
    """GIF89a, the logical screen without a global colour table (each frame has its own), looping forever."""
    screen = b"GIF89a" + struct.pack("<HHBBB", width, height, 0x70, 0, 0)
    return screen + b"!\xff\x0bNETSCAPE2.0\x03\x01" + struct.pack("<H", 0) + b"\x00"


def _sub_blocks_end(data: bytes, i: int) -> int:
    """The index after the data sub-blocks starting at ``i`` (each a length byte and that many bytes)."""
    while data[i]:
        i += data[i] + 1
    return i + 1


def _gif_frame(frame: np.ndarray, delay: int) -> bytes:
    """One frame of an animated GIF: its delay (1/100 s), its image with its own colour table.

    Pillow encodes the frame as a one-frame GIF (its palette and LZW data); its global colour table
    becomes the frame's local one, so each frame is written as it is rendered and none is kept
    (Pillow's own animated writer holds every frame until the end).
    """
    from PIL import Image  # Pillow (a dependency of matplotlib), only when a video is written

    buffer = io.BytesIO()
    Image.fromarray(frame).save(buffer, format="GIF")
    data = buffer.getvalue()
    flags = data[10]
    i = 13
    table = b""
    if flags & 0x80:
        table = data[i:i + 3 * 2 ** ((flags & 0x07) + 1)]
        i += len(table)
    while data[i] == 0x21:  # extensions Pillow may write: skipped (the delay is written below)
        i = _sub_blocks_end(data, i + 2)
    if data[i] != 0x2C:
        raise ValueError("video: Pillow wrote a frame skillbank cannot read back (no image descriptor)")
    descriptor = bytearray(data[i:i + 10])
    i += 10
    if descriptor[9] & 0x80:  # a local table already: kept as it is
        size = 3 * 2 ** ((descriptor[9] & 0x07) + 1)
        table, i = data[i:i + size], i + size
    elif table:
        descriptor[9] = (descriptor[9] & 0x40) | 0x80 | (flags & 0x07)
    end = _sub_blocks_end(data, i + 1)  # the LZW code size, then the image's sub-blocks
    control = b"!\xf9\x04\x00" + struct.pack("<H", delay) + b"\x00\x00"
    return control + bytes(descriptor) + table + data[i:end]


class Recorder:
    """Frames of the simulation, rendered off-screen and written to an animated GIF as they come.

    Each frame goes to a temporary file beside ``path`` when it is rendered (memory does not grow with
    the video's length); :meth:`write` ends the file and renames it into place, :meth:`close` without
    :meth:`write` removes it, so the GIF is written whole or not at all.
    """

    def __init__(self, mujoco, M, path, *, fps: float = 25.0, size=(480, 360)):
        width, height = (int(v) for v in size)
        try:
            self.renderer = mujoco.Renderer(M, height, width)
        except Exception as exc:  # a GL backend that fails here raises whatever its library raises
            raise ValueError(f"{NO_GL} ({type(exc).__name__})") from None
        self.mj, self.path, self.fps, self.frames = mujoco, Path(path), float(fps), 0
        self._size, self._delay = (width, height), max(1, int(round(100 / self.fps)))
        self._output = self._file = None
        self.camera = mujoco.MjvCamera()
        self.camera.lookat[:] = (0.0, -0.2, 0.25)
        self.camera.distance, self.camera.azimuth, self.camera.elevation = 1.9, 135.0, -25.0

    def add(self, d) -> None:
        """Render the scene of ``d`` and append it to the file."""
        self.renderer.update_scene(d, camera=self.camera)
        frame = np.asarray(self.renderer.render())
        if self._file is None:
            from ..io import atomic_output  # the one atomic writer

            self._output = atomic_output(self.path, name="video")
            self._file = open(self._output.__enter__(), "wb")  # noqa: SIM115 - closed by write or close
            self._file.write(_gif_header(*self._size))
        self._file.write(_gif_frame(frame, self._delay))
        self.frames += 1

    def close(self) -> None:
        """Free the GL context (explicitly: at interpreter exit EGL may already be gone); remove a GIF that
        was not finished by :meth:`write`."""
        renderer, self.renderer = self.renderer, None
        if renderer is not None:
            renderer.close()
        output, self._output = self._output, None
        if output is not None:
            self._file.close()
            stop = RuntimeError("the video was not finished")
            output.__exit__(RuntimeError, stop, None)  # the temporary file is removed

    def write(self) -> Path:
        """End the GIF and rename it into place."""
        if not self.frames:
            raise ValueError("video: the simulation rendered no frame")
        self._file.write(b";")
        self._file.close()
        output, self._output = self._output, None
        output.__exit__(None, None, None)
        return self.path
