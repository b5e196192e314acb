"""Bounds on what a simulation of a few bytes can ask for: physics steps and video frames.

A trajectory file of a few hundred bytes can span ``t = [0, 1e6]`` s: at 2 ms
steps the replay's arrays alone would take gigabytes. The steps (duration ×
rate) and the video's frames are counted before anything is allocated, and a
count over the bound is one ValueError saying how to go past it (an
environment variable, as ``SKILLBANK_MAX_EXPORT_SAMPLES`` does for exports).
"""

from __future__ import annotations

import math

from ..core._validation import env_bound

__all__ = ["MAX_STEPS", "STEPS_VARIABLE", "MAX_FRAMES", "FRAMES_VARIABLE", "max_steps", "max_frames",
           "check_steps", "check_frames"]

#: Physics steps one simulation replays at most: 70 min at the default 2 ms step (about 0.3 KB a step in
#: the result's time series, ~0.7 GB at the bound); ``SKILLBANK_MAX_SIMULATION_STEPS`` sets another.
MAX_STEPS = 2 ** 21
STEPS_VARIABLE = "SKILLBANK_MAX_SIMULATION_STEPS"
#: Frames one video holds at most: 10.9 min at 25 frames/s (each frame is written to the file as it is
#: rendered, so memory does not grow with them; the file does); ``SKILLBANK_MAX_VIDEO_FRAMES`` sets another.
MAX_FRAMES = 2 ** 14
FRAMES_VARIABLE = "SKILLBANK_MAX_VIDEO_FRAMES"


def max_steps(environ=None) -> int:
    """The bound on a simulation's physics steps: ``$SKILLBANK_MAX_SIMULATION_STEPS``, else 2^21.

    Examples
    --------
    >>> max_steps({}), max_steps({"SKILLBANK_MAX_SIMULATION_STEPS": "10000000"})
    (2097152, 10000000)
    """
    return env_bound(STEPS_VARIABLE, MAX_STEPS, "steps", environ)


def max_frames(environ=None) -> int:
    """The bound on a video's frames: ``$SKILLBANK_MAX_VIDEO_FRAMES``, else 2^14.

    Examples
    --------
    >>> max_frames({})
    16384
    """
    return env_bound(FRAMES_VARIABLE, MAX_FRAMES, "frames", environ)


def check_steps(duration: float, timestep: float, environ=None) -> int:
    """The physics steps replaying ``duration`` s takes, if within :func:`max_steps`, else a ValueError.

    Examples
    --------
    >>> check_steps(1.0, 0.002)
    501
    >>> check_steps(1e6, 0.002)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: trajectory: the simulation would take 5e+08 physics steps (1e+06 s at 2 ms a step), ...
    """
    bound = max_steps(environ)
    steps = math.floor(duration / timestep + 1e-9) + 1 if math.isfinite(duration / timestep) else math.inf
    if not steps <= bound:
        raise ValueError(f"trajectory: the simulation would take {float(steps):.4g} physics steps "
                         f"({duration:.4g} s at {timestep * 1000:.4g} ms a step), more than the bound of "
                         f"{bound} (set {STEPS_VARIABLE} to a larger number to simulate it, or shorten the "
                         "trajectory)")
    return int(steps)


def check_frames(steps: int, every: int, fps: float, environ=None) -> int:
    """The frames a video of ``steps`` physics steps (one frame ``every`` steps) holds, if within
    :func:`max_frames`, else a ValueError.

    Examples
    --------
    >>> check_frames(501, 20, 25.0)
    26
    """
    bound = max_frames(environ)
    frames = (steps - 1) // every + 1
    if frames > bound:
        raise ValueError(f"video: the video would hold {frames} frames ({frames / fps:.4g} s at {fps:.4g} "
                         f"frames/s), more than the bound of {bound} (set {FRAMES_VARIABLE} to a larger "
                         "number to render it, or leave out --video, or shorten the trajectory)")
    return frames
