"""Off-screen rendering of a simulation to an animated GIF (mujoco.Renderer, Pillow).

MuJoCo picks its OpenGL backend when it is first imported, from ``MUJOCO_GL``.
:func:`select_gl` sets it, before that import, to the first backend that
renders here (EGL, then OSMesa), each tried in a child process so that a
backend that crashes cannot take this one with it.
"""

from __future__ import annotations

import os
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


class Recorder:
    """Frames of the simulation, rendered off-screen, written as an animated GIF on :meth:`close`."""

    def __init__(self, mujoco, M, path, *, fps: float = 25.0, size=(480, 360)):
        width, height = (int(v) for v in size)
        try:
            self.renderer = mujoco.Renderer(M, height, width)
        except Exception as exc:  # a GL backend that fails here raises whatever its library raises
            raise ValueError(f"{NO_GL} ({type(exc).__name__})") from None
        self.mj, self.path, self.fps, self.frames = mujoco, Path(path), float(fps), []
        self.camera = mujoco.MjvCamera()
        self.camera.lookat[:] = (0.0, -0.2, 0.25)
        self.camera.distance, self.camera.azimuth, self.camera.elevation = 1.9, 135.0, -25.0

    def add(self, d) -> None:
        self.renderer.update_scene(d, camera=self.camera)
        self.frames.append(np.array(self.renderer.render()))

    def close(self) -> None:
        """Free the GL context (explicitly: at interpreter exit EGL may already be gone)."""
        renderer, self.renderer = self.renderer, None
        if renderer is not None:
            renderer.close()

    def write(self) -> Path:
        """The GIF, written whole or not at all."""
        from PIL import Image  # Pillow (a dependency of matplotlib), only when a video is written

        from ..io import atomic_output  # the one atomic writer

        if not self.frames:
            raise ValueError("video: the simulation rendered no frame")
        images = [Image.fromarray(f) for f in self.frames]
        with atomic_output(self.path, name="video") as tmp:
            images[0].save(tmp, save_all=True, append_images=images[1:], duration=int(round(1000 / self.fps)),
                           loop=0)
        return self.path
