"""A demonstration's phases: what its objects say the hand did (reach, carry, retreat), per object.

This is **the** place the phases of a manipulation demonstration are found; segmentation cuts at
them, and relations, evaluation and composition read them from here. A demonstration that records
the tool's position, one gripper (a discrete stream) and the poses of its objects (``X_pos`` (n, 3)
beside ``X_quat`` (n, 4)) is cut where the gripper switches *and something changes hands*:

- a **carry** of an object runs from the gripper switch that takes it to the one that lets it go,
  and holds it if the object moved with the tool over that time (:func:`carried`): its motion is
  explained by the tool's, not by its settling on the table at reset or by being pushed aside;
- a **reach** for an object runs from where the last phase ended (the start, or a release) to the
  switch that takes it: everything the hand did on the way, its pauses, overshoots and corrections,
  and a grasp that closed on nothing and opened again, is one reach;
- a **retreat** runs from the last release to the end.

A person moves in bursts (a human Lift demonstration's hand is still 56 % of the time, 13 stops):
the motion's own cuts fall inside these phases, and a phase is not cut again there, so one approach
to one object is one primitive whatever its pauses. A demonstration in which nothing changes hands
(no object poses, no gripper, or a gripper that never held anything) has no phases: the motion
alone cuts it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core import Demonstration, quaternion_to_matrix
from ..core._rotations import check_quaternions
from ._events import discrete_events, stream_kind

__all__ = ["Phase", "PHASE_KINDS", "object_streams", "carried", "travel_with_tool", "demonstration_phases",
           "phase_bounds"]

#: What a phase does: reach for an object, carry it, or leave the last one let go of.
PHASE_KINDS = ("reach", "carry", "retreat")

#: How far (m) an object must move while the gripper holds its state for it to have been carried: the
#: same travel :func:`~skillbank.selection.acted_on` asks of a carried object.
MOVED = 0.01


@dataclass(frozen=True)
class Phase:
    """One phase of a demonstration.

    Attributes
    ----------
    kind : str
        One of :data:`PHASE_KINDS`.
    start, stop : int
        Its samples, ``start`` to ``stop`` (exclusive).
    object : str or None
        The object reached for, carried, or retreated from.
    """

    kind: str
    start: int
    stop: int
    object: str | None

    def to_dict(self) -> dict:
        return {"kind": self.kind, "start": self.start, "stop": self.stop, "object": self.object}


def object_streams(demo: Demonstration) -> list:
    """Names of the objects whose pose ``demo`` records (``X_pos`` (n, 3) beside ``X_quat`` (n, 4)).

    Examples
    --------
    >>> t = np.arange(3.0)
    >>> d = Demonstration(t, {"position": np.zeros((3, 3)), "cube_pos": np.zeros((3, 3)),
    ...                       "cube_quat": np.tile([0.0, 0.0, 0.0, 1.0], (3, 1))})
    >>> object_streams(d)
    ['cube']
    """
    out = []
    for name in demo.stream_names:
        if name.endswith("_pos") and "_to_" not in name:  # robosuite's relative poses are not objects
            base = name[:-4]
            if f"{base}_quat" in demo.streams and demo[name].shape[1:] == (3,) \
                    and demo[f"{base}_quat"].shape[1:] == (4,):
                out.append(base)
    return sorted(out)


def carried(demo: Demonstration, obj: str, start: int = 0, stop: int | None = None, *,
            moved: float = MOVED) -> float:
    """How far (m) the tool carried ``obj`` over samples ``start:stop``, or 0 if it did not carry it.

    The object is carried when it travels more than ``moved`` and the tool's motion explains it: at the
    sample where it is farthest from where it was, its shift in the tool's frame (what the tool's own
    motion, the wrist's turns included, does not account for) is less than half its travel. A cube that
    settles by a centimetre at reset while the hand waits above it moved, but not with the tool; a cube
    lifted 5 cm shifts a few millimetres in the fingers as they close on it off centre.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 5)
    >>> tool = np.column_stack([0 * t, 0 * t, 0.1 + 0.1 * t])
    >>> d = Demonstration(t, {"position": tool, "cube_pos": tool - [0, 0, 0.08],
    ...                       "cube_quat": np.tile([0.0, 0.0, 0.0, 1.0], (5, 1))})
    >>> round(carried(d, "cube"), 3)
    0.1
    >>> settles = Demonstration(t, {"position": 0 * tool + 0.2, "cube_pos": tool - [0, 0, 0.08],
    ...                             "cube_quat": np.tile([0.0, 0.0, 0.0, 1.0], (5, 1))})
    >>> carried(settles, "cube")
    0.0
    """
    stop = demo.n_steps if stop is None else stop
    if stop - start < 2:
        return 0.0
    P = np.asarray(demo["position"][start:stop], float)
    W = np.asarray(demo[f"{obj}_pos"][start:stop], float)  # where the object is
    offset = W - P
    if "orientation" in demo.streams and demo["orientation"].shape[1:] == (4,):
        R = quaternion_to_matrix(check_quaternions(demo["orientation"][start:stop], name="orientation"))
        offset = np.einsum("nji,nj->ni", R, offset)
    return travel_with_tool(W, offset, moved=moved)


def travel_with_tool(where, offset, *, moved: float = MOVED) -> float:
    """How far (m) an object travelled with the tool, or 0: :func:`carried`'s test on the object's
    positions ``where`` (n, 3) and its ``offset`` from the tool in the tool's frame (n, 3).

    Examples
    --------
    >>> where = np.array([[0.0, 0.0, 0.02], [0.0, 0.0, 0.07]])
    >>> travel_with_tool(where, np.zeros((2, 3)))  # lifted 5 cm where the fingers hold it
    0.05
    """
    where, offset = np.asarray(where, float), np.asarray(offset, float)
    if len(where) < 2:
        return 0.0
    travel = np.linalg.norm(where - where[0], axis=1)
    k = int(np.argmax(travel))
    if travel[k] <= moved:
        return 0.0
    shift = float(np.linalg.norm(offset[k] - offset[0]))
    return float(travel[k]) if shift < 0.5 * travel[k] else 0.0


def _gripper(demo: Demonstration, stream_kinds=None) -> str | None:
    """The demonstration's one discrete stream (its gripper), or None if it has none or several."""
    names = [s for s in demo.stream_names if stream_kind(s, stream_kinds) == "discrete"]
    return names[0] if len(names) == 1 else None


def demonstration_phases(demo: Demonstration, *, stream_kinds=None, moved: float = MOVED) -> list:
    """The :class:`Phase` list of ``demo``, covering all its samples in order; empty without phases.

    Parameters
    ----------
    demo : Demonstration
        With a ``position`` stream (the tool's, m), optionally ``orientation`` (x, y, z, w), one
        discrete stream (the gripper; by name, or as ``stream_kinds`` says) and object poses
        (:func:`object_streams`).
    stream_kinds : dict, optional
        Stream kinds, as :class:`~skillbank.segmentation.MultimodalSegmenter` takes them.
    moved : float, default=0.01
        How far (m) a carried object must travel.

    Returns
    -------
    list of Phase
        Empty when nothing changes hands: no tool position, no single gripper, no objects, or no
        stretch between two gripper switches over which the tool carried an object.

    Examples
    --------
    >>> t = np.linspace(0.0, 3.0, 31)
    >>> tool = np.column_stack([np.clip(t, 0, 1) * 0.3, 0 * t, 0.2 - 0.1 * np.clip(t, 0, 1)
    ...                         + 0.1 * np.clip(t - 1.5, 0, 1)])
    >>> cube = np.where((t >= 1.2)[:, None], tool - [0, 0, 0.08], [0.3, 0.0, 0.02])
    >>> grip = (t >= 1.2).astype(float)[:, None]
    >>> d = Demonstration(t, {"position": tool, "gripper": grip, "cube_pos": cube,
    ...                       "cube_quat": np.tile([0.0, 0.0, 0.0, 1.0], (31, 1))})
    >>> [(p.kind, p.start, p.stop, p.object) for p in demonstration_phases(d)]
    [('reach', 0, 11, 'cube'), ('carry', 11, 31, 'cube')]
    """
    if not isinstance(demo, Demonstration):
        raise ValueError(f"demo: expected a skillbank.Demonstration, got {type(demo).__name__}")
    objects = object_streams(demo)
    grip = _gripper(demo, stream_kinds)
    if not objects or grip is None or "position" not in demo.streams or demo["position"].shape[1:] != (3,):
        return []
    n = demo.n_steps
    switches = discrete_events(demo[grip])[0]
    edges = [0, *[int(s) for s in switches if 0 < s < n], n]
    carries = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        # between two switches the gripper holds one state; what moved with the tool then was held
        moves = [(carried(demo, obj, a, b, moved=moved), obj) for obj in objects]
        travel, obj = max(moves)
        if travel > 0.0:
            carries.append((a, b, obj))
    if not carries:
        return []
    out, cursor = [], 0
    for a, b, obj in carries:
        if a > cursor:
            out.append(Phase("reach", cursor, a, obj))
        out.append(Phase("carry", a, b, obj))
        cursor = b
    if cursor < n:
        out.append(Phase("retreat", cursor, n, carries[-1][2]))
    return out


def phase_bounds(phases, n: int, min_size: int = 1) -> np.ndarray:
    """The keypoints (sample indices where a phase begins, 0 and ``n`` excluded) of ``phases``, with a
    phase shorter than ``min_size`` samples joined to its shorter neighbour (a release at the very end).

    Examples
    --------
    >>> ph = [Phase("reach", 0, 40, "cube"), Phase("carry", 40, 97, "cube"), Phase("retreat", 97, 100,
    ...       "cube")]
    >>> phase_bounds(ph, 100, min_size=8).tolist()
    [40]
    """
    edges = [0, *[p.start for p in phases[1:]], n]
    while len(edges) > 2:
        sizes = np.diff(edges)
        k = int(np.argmin(sizes))
        if sizes[k] >= min_size:
            break
        # drop the boundary to the shorter neighbour; the first and last phases have one neighbour
        if k == 0:
            del edges[1]
        elif k == len(sizes) - 1:
            del edges[-2]
        else:
            del edges[k if sizes[k - 1] <= sizes[k + 1] else k + 1]
    return np.asarray(edges[1:-1], dtype=int)
