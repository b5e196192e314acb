"""Scene files: the objects, obstacles, facts, goal and start of a task to plan.

A scene is JSON (documented in ``docs/planning.md``)::

    {"objects": {"b1": {"type": "button", "position": [0.1, -0.5, 0.15], "orientation": [0, 1, 0, 0]}},
     "obstacles": ["sphere:0.0,-0.5,0.2,0.03"],
     "init": ["(free b1)"],
     "goal": ["(pressed b1)"],
     "start": {"position": [0.0, -0.45, 0.4], "orientation": [0, 1, 0, 0]}}

Obstacles use the ``--obstacle`` syntax (a list, named ``obstacles[k]``, or an
object of named specs); orientations are scalar-last unit quaternions; an
object's orientation is the tool's orientation at it. ``start`` may give
``joints`` instead of a pose (with a robot), and a ``gripper`` value.
Optional ``domain`` names a PDDL file beside the scene (never outside its folder);
optional ``branch`` names the robot's inverse-kinematics branch for every step
(``"shoulder-left/elbow-up/wrist-up"``, see docs/robots.md).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import parse_obstacle
from ..core._constraints import Constraints
from ..core._rotations import check_quaternions
from ._json import check_depth, describe, load_json, number, numbers, short
from ._pddl import _check_name, parse_atom

__all__ = ["Scene", "SceneObject", "load_scene", "scene_from_dict", "SCENE_KEYS", "MAX_SCENE_BYTES"]

SCENE_KEYS = ("objects", "obstacles", "init", "goal", "start", "domain", "branch")
_START_KEYS = ("position", "orientation", "joints", "gripper")
_OBJECT_KEYS = ("type", "position", "orientation")
#: Largest scene file read (a scene of thousands of objects is far smaller).
MAX_SCENE_BYTES = 16 * 2 ** 20


@dataclass
class SceneObject:
    """An object of the scene: its PDDL type and, optionally, a pose (position and tool orientation)."""

    name: str
    type: str
    position: np.ndarray | None = None
    orientation: np.ndarray | None = None
    #: Physical shape (None: a point the planner knows only as a pose): "button", "box", "cylinder",
    #: "sphere". A button's position is the centre of its top face; a body's is its centre.
    shape: str | None = None
    #: Button: (radius,); box: full extents (x, y, z); cylinder: (radius, height); sphere: (radius,). Metres.
    size: np.ndarray | None = None
    #: Button: how far its cap moves down before it bottoms out (metres).
    travel: float | None = None
    #: Movable bodies: kg (None for buttons and fixed bodies).
    mass: float | None = None


@dataclass
class Scene:
    """A checked scene (see the module docstring).

    Attributes
    ----------
    objects : dict
        Name -> :class:`SceneObject`, in file order.
    obstacles : dict
        Name -> :class:`~skillbank.core.Obstacle`; ``"obstacles[k]"`` for a list.
    specs : dict
        Name -> the obstacle's spec text.
    init, goal : list of (str, tuple)
        Ground atoms ``(predicate, args)``.
    start : dict
        ``position``, ``orientation``, ``joints``, ``gripper`` (each None when not given).
    domain : pathlib.Path or None
        A PDDL domain file beside the scene.
    folder : pathlib.Path or None
    branch : str or None
        The robot's inverse-kinematics branch (checked against the robot's names when a plan runs).
    """

    objects: dict
    obstacles: dict
    init: list
    goal: list
    start: dict = field(default_factory=dict)
    specs: dict = field(default_factory=dict)
    domain: Path | None = None
    folder: Path | None = None
    branch: str | None = None
    #: The table: a :class:`~skillbank.core.Box` whose top is the table's surface, or None.
    table: object = None
    #: Workspace bounds ``(lower (3,), upper (3,))`` the whole robot stays within, or None.
    workspace: tuple | None = None

    def constraints(self, names=None) -> Constraints:
        """:class:`~skillbank.core.Constraints` holding the obstacles ``names`` (default all)."""
        names = list(self.obstacles) if names is None else names
        return Constraints(obstacles=[self.obstacles[n] for n in names])

    def pose(self, name: str):
        """``(position, orientation)`` of object ``name`` (either may be None)."""
        obj = self.objects[name]
        return obj.position, obj.orientation


def _unknown(doc: dict, allowed, where: str) -> None:
    extra = sorted(set(doc) - set(allowed), key=str)
    if extra:
        raise ValueError(f"{where}: unknown key {short(extra[0])}; expected keys among {list(allowed)}")


def _quaternion(value, where: str) -> np.ndarray:
    return check_quaternions(numbers(value, where, 4), name=where)


def _object(name, doc, where: str) -> SceneObject:
    _check_name(str(name).lower(), "an object name", where)
    if not isinstance(doc, dict):
        raise ValueError(f"{where}: expected an object with 'type' and optionally 'position' and "
                         f"'orientation', got {describe(doc)}")
    _unknown(doc, _OBJECT_KEYS, where)
    if "type" not in doc:
        raise ValueError(f"{where}.type: expected a PDDL type name, got none")
    if not isinstance(doc["type"], str):
        raise ValueError(f"{where}.type: expected a PDDL type name (a string such as 'button'), got "
                         f"{describe(doc['type'])}")
    kind = _check_name(doc["type"].lower(), "a PDDL type name", f"{where}.type")
    position = None if doc.get("position") is None else numbers(doc["position"], f"{where}.position", 3)
    orientation = None if doc.get("orientation") is None else _quaternion(doc["orientation"],
                                                                           f"{where}.orientation")
    return SceneObject(str(name).lower(), kind, position, orientation)


def _obstacles(value) -> tuple[dict, dict]:
    if isinstance(value, list):
        items = [(f"obstacles[{k}]", v) for k, v in enumerate(value)]
    elif isinstance(value, dict):
        items = [(str(k), v) for k, v in value.items()]
    else:
        raise ValueError(f"obstacles: expected a list (or an object) of specs like 'sphere:X,Y,Z,R', got "
                         f"{describe(value)}")
    obstacles, specs = {}, {}
    for name, spec in items:
        where = name if name.startswith("obstacles[") else f"obstacles[{short(name)}]"
        if not isinstance(spec, str):
            raise ValueError(f"{where}: expected a spec string like 'sphere:X,Y,Z,R', got {describe(spec)}")
        try:
            ob = parse_obstacle(spec)
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
        if ob.n_dims != 3:
            raise ValueError(f"{where}: expected a 3-D obstacle, got a {ob.n_dims}-D {short(spec)}")
        obstacles[name], specs[name] = ob, spec
    return obstacles, specs


def _atoms(value, key: str, objects: dict) -> list:
    if not isinstance(value, list):
        raise ValueError(f"{key}: expected a list of atoms like '(pressed b1)', got {describe(value)}")
    out = []
    for k, text in enumerate(value):
        pred, args = parse_atom(text, f"{key}[{k}]")
        unknown = [a for a in args if a not in objects]
        if unknown:
            raise ValueError(f"{key}[{k}]: {short(text)} names {short(unknown[0])}, which is not an object "
                             f"of the scene (objects {list(objects)[:8]})")
        out.append((pred, args))
    return out


def _start(value) -> dict:
    if not isinstance(value, dict):
        raise ValueError(f"start: expected an object with 'position' and 'orientation' or 'joints', got "
                         f"{describe(value)}")
    _unknown(value, _START_KEYS, "start")
    out = dict.fromkeys(_START_KEYS)
    if value.get("position") is not None:
        out["position"] = numbers(value["position"], "start.position", 3)
    if value.get("orientation") is not None:
        out["orientation"] = _quaternion(value["orientation"], "start.orientation")
    if value.get("joints") is not None:
        out["joints"] = numbers(value["joints"], "start.joints")
        if out["position"] is not None or out["orientation"] is not None:
            raise ValueError("start: expected a pose (position, orientation) or joints, got both")
    if value.get("gripper") is not None:
        out["gripper"] = number(value["gripper"], "start.gripper")
    return out


def _confined(folder: Path | None, entry, key: str) -> Path:
    if not isinstance(entry, str) or not entry or "\x00" in entry:
        raise ValueError(f"{key}: expected a file name relative to the scene's folder, got {describe(entry)}")
    if folder is None:
        raise ValueError(f"{key}: a scene read from a dict has no folder for {short(entry)}; load it from a "
                         "file")
    root = os.path.realpath(folder)
    real = os.path.realpath(os.path.join(root, entry))
    if os.path.commonpath([root, real]) != root:
        raise ValueError(f"{key}: expected a file inside the scene's folder, got {short(entry)}, which "
                         "leads outside it")
    if not os.path.isfile(real):
        raise ValueError(f"{key}: expected a file beside the scene, got {short(entry)}, which is not a file")
    return Path(real)


def scene_from_dict(doc, *, folder=None) -> Scene:
    """Check a parsed scene; ``folder`` is where its file lives (for ``domain``).

    Raises
    ------
    ValueError
        Naming the key (``objects['b1'].position``, ``goal[2]``, ...), what was
        expected and what was found.

    Examples
    --------
    >>> s = scene_from_dict({"objects": {"b1": {"type": "button", "position": [0.1, -0.5, 0.15]}},
    ...                      "init": ["(free b1)"], "goal": ["(pressed b1)"]})
    >>> s.goal, s.objects["b1"].position.tolist()
    ([('pressed', ('b1',))], [0.1, -0.5, 0.15])
    >>> scene_from_dict({"objects": {}, "goal": ["(pressed b9)"]})
    Traceback (most recent call last):
    ...
    ValueError: goal[0]: '(pressed b9)' names 'b9', which is not an object of the scene (objects [])
    """
    if not isinstance(doc, dict):
        raise ValueError(f"scene: expected a JSON object with keys {list(SCENE_KEYS)}, "
                         f"got {describe(doc)}")
    check_depth(doc, "scene")  # before anything walks it: a deep or self-containing dict is one line
    _unknown(doc, SCENE_KEYS, "scene")
    raw = doc.get("objects", {})
    if not isinstance(raw, dict):
        raise ValueError(f"objects: expected an object of name -> {{type, position, orientation}}, got "
                         f"{describe(raw)}")
    objects = {}
    for name, value in raw.items():
        obj = _object(name, value, f"objects[{short(name)}]")
        if obj.name in objects:
            raise ValueError(f"objects[{short(name)}]: expected unique names (case-insensitive), got it "
                             "twice")
        objects[obj.name] = obj
    obstacles, specs = _obstacles(doc.get("obstacles", []))
    if doc.get("goal") is None or doc["goal"] == []:
        raise ValueError("goal: expected a non-empty list of atoms like '(pressed b1)', got "
                         f"{'none' if doc.get('goal') is None else 'an empty list'}")
    folder = None if folder is None else Path(folder)
    branch = doc.get("branch")
    if branch is not None and (not isinstance(branch, str) or not branch.strip()):
        raise ValueError(f"branch: expected the name of an inverse-kinematics branch like "
                         f"'shoulder-left/elbow-up/wrist-up', got {branch!r}")
    return Scene(objects=objects, obstacles=obstacles, specs=specs,
                 init=_atoms(doc.get("init", []), "init", objects), goal=_atoms(doc["goal"], "goal", objects),
                 start=_start(doc.get("start", {})),
                 domain=None if doc.get("domain") is None else _confined(folder, doc["domain"], "domain"),
                 folder=folder, branch=branch)


def load_scene(path) -> Scene:
    """Read and check a scene file (JSON; see the module docstring).

    Examples
    --------
    >>> import json, os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "scene.json")
    >>> with open(path, "w") as fh:
    ...     json.dump({"objects": {"b1": {"type": "button", "position": [0, 0, 0]}},
    ...                "goal": ["(pressed b1)"]}, fh)
    >>> list(load_scene(path).objects)
    ['b1']
    """
    path = Path(path)
    doc = load_json(path, "scene", MAX_SCENE_BYTES)
    return scene_from_dict(doc, folder=path.resolve().parent)
