"""How a skill's action binds to geometry: its goal pose, obstacles, gripper, method and timing.

A skill's description is a PDDL action schema plus a *binding*, a JSON object
with any of these keys (every one optional):

``goal``
    The parameter (``"?b"``) whose object's pose is the step's goal. Default:
    the one argument that is an object with a position; an action with more
    than one such argument must name it (no guess is made).
``offset``
    ``[dx, dy, dz]`` added to that position (world frame, metres); default none.
``orientation``
    ``"object"`` (default: the object's orientation, when it has one),
    ``"none"`` (leave the orientation free), or a quaternion ``[x, y, z, w]``.
``obstacles``
    ``"all"`` (default) or a list of the scene's obstacle names that apply.
``gripper``
    ``{"start": value, "end": value}``: the gripper command at the step's first
    and last sample (held in between at ``start``); default the skill's recorded
    gripper, else the value carried from the previous step.
``method``, ``k``, ``duration``
    The reuse's representation (default ``"lte"``), candidates, seconds.
``velocity``
    ``"zero"`` (default: the step starts and ends at rest) or ``"free"``.
``approach``, ``retreat``
    A distance (m) along the tool axis, or an offset ``[dx, dy, dz]`` (world
    frame, m) from the goal: the step's primitive ends at the approach point
    (``goal - d * z_tool``, or ``goal + offset``), a straight line at rest at
    both ends brings the tool down onto the goal with its orientation held,
    and another leaves it to the retreat point the same way. ``z_tool`` is the
    goal orientation's z axis (the tool points along its frame's +z).
``transit``
    ``{"height": z}`` (m), or ``"none"``: overrides the scene's ``transit`` for
    this skill (see :func:`skillbank.planning.reproduce_plan`).
``object``, ``target``
    In a physics scene (``skillbank plan --scene robosuite:TASK``): the parameter bound to the object
    the skill's primitives act on (reach or carry), and the one bound to where a carried object goes.
    Default: the action's first and second parameters.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core._rotations import check_quaternions
from ..core._validation import check_positive
from ..representations import REPRESENTATIONS
from ._json import check_depth, describe, number, numbers, short

__all__ = ["Binding", "check_binding", "BINDING_KEYS", "DEFAULT_METHOD"]

BINDING_KEYS = ("goal", "offset", "orientation", "obstacles", "gripper", "method", "k", "duration",
                "velocity", "approach", "retreat", "transit", "object", "target")
#: The representation a plan step uses unless its binding names another: LTE edits the best
#: candidate itself, so each step stays one recorded motion, met to round-off.
DEFAULT_METHOD = "lte"


@dataclass
class Binding:
    """A checked binding (see the module docstring); ``as_dict`` gives back the JSON form."""

    goal: str | None = None
    offset: np.ndarray | None = None
    orientation: object = "object"
    obstacles: object = "all"
    gripper_start: float | None = None
    gripper_end: float | None = None
    method: str = DEFAULT_METHOD
    k: int | None = None
    duration: float | None = None
    velocity: str = "zero"
    #: A distance (float, m) along the tool axis, or an offset (ndarray (3,), m); None for none.
    approach: object = None
    retreat: object = None
    #: The transit height (m), "none" (no transit for this skill), or None (the scene's).
    transit: object = None
    #: The parameters bound to what the primitives act on and to a carried object's target (None: default).
    object: str | None = None
    target: str | None = None

    def as_dict(self) -> dict:
        """The JSON-able binding, with only what differs from the defaults."""
        out = {}
        for key in ("goal", "object", "target"):
            if getattr(self, key) is not None:
                out[key] = getattr(self, key)
        if self.offset is not None:
            out["offset"] = self.offset.tolist()
        if not isinstance(self.orientation, str):
            out["orientation"] = np.asarray(self.orientation).tolist()
        elif self.orientation != "object":
            out["orientation"] = self.orientation
        if self.obstacles != "all":
            out["obstacles"] = list(self.obstacles)
        ends = (("start", self.gripper_start), ("end", self.gripper_end))
        gripper = {k: v for k, v in ends if v is not None}
        if gripper:
            out["gripper"] = gripper
        if self.method != DEFAULT_METHOD:
            out["method"] = self.method
        for key in ("k", "duration"):
            if getattr(self, key) is not None:
                out[key] = getattr(self, key)
        if self.velocity != "zero":
            out["velocity"] = self.velocity
        for key in ("approach", "retreat"):
            value = getattr(self, key)
            if value is not None:
                out[key] = value.tolist() if isinstance(value, np.ndarray) else value
        if self.transit is not None:
            out["transit"] = self.transit if self.transit == "none" else {"height": self.transit}
        return out


def _distance(value, where: str):
    """A distance along the tool axis (a positive number) or a world offset (3 numbers, not all zero)."""
    if isinstance(value, (list, tuple, np.ndarray)):
        offset = numbers(value, where, 3)
        if not np.any(offset):
            raise ValueError(f"{where}: expected an offset [dx, dy, dz] that is not zero, got [0, 0, 0]")
        return offset
    d = number(value, where) if isinstance(value, (int, float, np.number)) and not isinstance(value, bool) \
        else None
    if d is None or d <= 0.0:
        raise ValueError(f"{where}: expected a distance along the tool axis (a positive number, metres) or "
                         f"an offset [dx, dy, dz], got {describe(value)}")
    return d


def check_binding(doc, parameters=(), *, name: str = "binding") -> Binding:
    """Check a binding against an action's parameters (``[(name, type)]``).

    Examples
    --------
    >>> b = check_binding({"goal": "?b", "offset": [0, 0, 0.01]}, [("?b", "button")])
    >>> b.goal, b.offset.tolist(), b.method
    ('?b', [0.0, 0.0, 0.01], 'lte')
    >>> check_binding({"goal": "?x"}, [("?b", "button")])
    Traceback (most recent call last):
    ...
    ValueError: binding.goal: expected a parameter of the action (['?b']), got '?x'
    """
    if doc is None:
        doc = {}
    if not isinstance(doc, dict):
        raise ValueError(f"{name}: expected a JSON object with keys among {list(BINDING_KEYS)}, got "
                         f"{type(doc).__name__}")
    check_depth(doc, name)  # before any message shows a part of it
    extra = sorted(set(doc) - set(BINDING_KEYS), key=str)
    if extra:
        raise ValueError(f"{name}: unknown key {short(extra[0])}; expected keys among {list(BINDING_KEYS)}")
    out = Binding()
    names = [p for p, _ in parameters]
    for key in ("goal", "object", "target"):
        if doc.get(key) is None:
            continue
        value = doc[key].lower() if isinstance(doc[key], str) else doc[key]
        if value not in names:
            got = short(doc[key]) if isinstance(doc[key], str) else describe(doc[key])
            raise ValueError(f"{name}.{key}: expected a parameter of the action ({names}), got {got}")
        setattr(out, key, value)
    if doc.get("offset") is not None:
        out.offset = numbers(doc["offset"], f"{name}.offset", 3)
    orientation = doc.get("orientation", "object")
    if isinstance(orientation, str):
        if orientation not in ("object", "none"):
            raise ValueError(f"{name}.orientation: expected 'object', 'none' or a quaternion [x, y, z, w], "
                             f"got {short(orientation)}")
        out.orientation = orientation
    else:
        if isinstance(orientation, (list, tuple)) and len(orientation) != 4:
            raise ValueError(f"{name}.orientation: expected a quaternion of 4 numbers, got "
                             f"{len(orientation)}")
        q = numbers(orientation, f"{name}.orientation", 4)
        out.orientation = check_quaternions(q, name=f"{name}.orientation")
    obstacles = doc.get("obstacles", "all")
    if obstacles != "all" and (not isinstance(obstacles, list)
                               or not all(isinstance(o, str) for o in obstacles)):
        raise ValueError(f"{name}.obstacles: expected 'all' or a list of obstacle names, got "
                         f"{describe(obstacles)}")
    out.obstacles = obstacles
    gripper = doc.get("gripper", {})
    if not isinstance(gripper, dict) or set(gripper) - {"start", "end"}:
        raise ValueError(f"{name}.gripper: expected an object with 'start' and/or 'end', got "
                         f"{describe(gripper)}")
    for key in ("start", "end"):
        if gripper.get(key) is not None:
            value = number(gripper[key], f"{name}.gripper.{key}")
            setattr(out, f"gripper_{key}", value)
    method = doc.get("method", DEFAULT_METHOD)
    if not isinstance(method, str) or method not in REPRESENTATIONS:
        raise ValueError(f"{name}.method: expected one of {list(REPRESENTATIONS)}, got {describe(method)}")
    out.method = method
    if doc.get("k") is not None:
        out.k = check_positive(doc["k"], name=f"{name}.k", integer=True)
    if doc.get("duration") is not None:
        out.duration = check_positive(doc["duration"], name=f"{name}.duration")
    velocity = doc.get("velocity", "zero")
    if velocity not in ("zero", "free"):
        raise ValueError(f"{name}.velocity: expected 'zero' or 'free', got {describe(velocity)}")
    out.velocity = velocity
    for key in ("approach", "retreat"):
        if doc.get(key) is not None:
            setattr(out, key, _distance(doc[key], f"{name}.{key}"))
    transit = doc.get("transit")
    if transit is not None:
        if transit == "none":
            out.transit = "none"
        elif isinstance(transit, dict) and set(transit) == {"height"}:
            out.transit = number(transit["height"], f"{name}.transit.height")
        else:
            raise ValueError(f"{name}.transit: expected {{\"height\": z}} (metres) or 'none', got "
                             f"{describe(transit)}")
    return out
