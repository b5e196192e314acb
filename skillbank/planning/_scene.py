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

A scene can also describe its world (all optional; docs/planning.md has a full example):

``table``
    ``{"height": z}``: a table top at ``z``, :data:`TABLE_THICKNESS` thick,
    spanning the workspace's x and y when one is given, else
    :data:`TABLE_HALF_EXTENT` either side of the robot's base (the scene's
    origin); or ``{"box": [x0, y0, z0, x1, y1, z1]}``, the slab itself (its top
    face, ``z1``, is the surface).
``workspace``
    ``{"lower": [x, y, z], "upper": [x, y, z]}``: the box the robot stays within.
``transit``
    ``{"height": z}``: moves between steps go up to ``z``, across and down,
    unless the step's primitive already reaches that height.
object ``shape``, ``size``, ``travel``, ``mass``, ``friction``
    ``"button"`` (size ``[radius]``, a ``travel``), ``"box"`` (full extents
    ``[x, y, z]``), ``"cylinder"`` (``[radius, height]``), ``"sphere"``
    (``[radius]``); metres, kilograms. A positioned object of type ``button``
    without a shape is a button of :data:`BUTTON_SIZE` and
    :data:`BUTTON_TRAVEL`. A button's ``position`` is the centre of its top
    face (where the tool presses); a body's is its centre. A body with a
    ``mass`` is movable; without one it is fixed.

Positions are the robot's tool frame (its TCP when the robot's tool is the
gripper's TCP): a button's position is where the tool presses.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import Box, Sphere, parse_obstacle
from ..core._constraints import Constraints
from ..core._rotations import check_quaternions
from ._json import check_depth, describe, load_json, number, numbers, short
from ._pddl import _check_name, parse_atom

__all__ = ["Scene", "SceneObject", "load_scene", "scene_from_dict", "workspace_slabs", "SCENE_KEYS",
           "MAX_SCENE_BYTES", "SHAPES", "BUTTON_SIZE", "BUTTON_TRAVEL", "TABLE_THICKNESS",
           "TABLE_HALF_EXTENT", "WORKSPACE_SLAB"]

SCENE_KEYS = ("objects", "obstacles", "init", "goal", "start", "domain", "branch", "table", "workspace",
              "transit")
_START_KEYS = ("position", "orientation", "joints", "gripper")
_OBJECT_KEYS = ("type", "position", "orientation", "shape", "size", "travel", "mass", "friction")
#: Object shapes and what their ``size`` lists (metres).
SHAPES = {"button": ("radius",), "box": ("x", "y", "z"), "cylinder": ("radius", "height"),
          "sphere": ("radius",)}
#: A button's default size ``[radius]`` and travel (m): a common 40 mm panel push button, whose cap moves
#: 4 mm before it bottoms out.
BUTTON_SIZE = (0.02,)
BUTTON_TRAVEL = 0.004
#: Thickness (m) of a table given by its height: a solid table top, so that a path through it is caught.
TABLE_THICKNESS = 0.05
#: Half-width (m) in x and y of a table given by its height, around the robot's base, without a workspace.
TABLE_HALF_EXTENT = 2.0
#: Thickness (m) of the slabs outside the workspace's faces that the tool point is kept out of.
WORKSPACE_SLAB = 0.05
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
    #: Sliding friction coefficient of its surface (None: the simulator's default).
    friction: float | None = None


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
    table : Box or None
        The table, a slab whose top face is the surface.
    workspace : tuple of ndarray or None
        ``(lower, upper)`` corners of the box the robot stays within.
    transit : float or None
        Height (m) of the moves between steps.
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
    #: Height (m) the moves between steps go up to (``transit.height``), or None.
    transit: float | None = None

    def solid(self, name: str):
        """The space object ``name`` fills, as an obstacle, or None (no shape: a pose only).

        A button: its cap and housing, a box of its radius from its top face down to the table (5 cm
        where there is none); a box: its extents; a cylinder: the box around it; a sphere: itself. The
        whole-robot check of a plan keeps the robot out of the objects a step does not act on.

        Examples
        --------
        >>> s = scene_from_dict({"objects": {"b1": {"type": "button", "position": [0.1, -0.5, 0.15]}},
        ...                      "goal": ["(pressed b1)"], "table": {"height": 0.1}})
        >>> s.solid("b1")
        Box([0.08, -0.52, 0.1], [0.12000000000000001, -0.48, 0.15])
        """
        obj = self.objects[name]
        shape, size, p = obj.shape, obj.size, obj.position
        if shape is None or size is None or p is None:
            return None
        size = np.asarray(size, dtype=float)
        if shape == "button":
            floor = float(self.table.upper[2]) if self.table is not None else p[2] - 0.05
            r = float(size[0])
            return Box([p[0] - r, p[1] - r, min(floor, p[2] - 1e-3)], [p[0] + r, p[1] + r, p[2]])
        if shape == "box":
            return Box(p - size / 2, p + size / 2)
        if shape == "cylinder":
            r, h = float(size[0]), float(size[1])
            return Box(p - [r, r, h / 2], p + [r, r, h / 2])
        if shape == "sphere":
            return Sphere(p, float(size[0]))
        return None

    def world(self, names=None) -> list:
        """``[(label, Obstacle)]`` the tool point stays out of: obstacles ``names`` (default all), the table,
        and a slab :data:`WORKSPACE_SLAB` thick outside each face of the workspace.

        Labels read in messages: ``"obstacle wall (box:...)"``, ``"the table (top at z = 0 m)"``,
        ``"the workspace's bound z <= 0.8 m"``.

        Examples
        --------
        >>> s = scene_from_dict({"objects": {"b1": {"type": "button", "position": [0.1, -0.5, 0.15]}},
        ...                      "goal": ["(pressed b1)"], "table": {"height": 0.0},
        ...                      "workspace": {"lower": [-1, -1, -0.1], "upper": [1, 1, 1]}})
        >>> [label for label, _ in s.world()][:3]
        ['the table (top at z = 0 m)', "the workspace's bound x >= -1 m", "the workspace's bound x <= 1 m"]
        >>> s.table
        Box([-1.0, -1.0, -0.05], [1.0, 1.0, 0.0])
        """
        names = list(self.obstacles) if names is None else names
        out = [(f"obstacle {n} ({self.specs.get(n, self.obstacles[n].spec())})", self.obstacles[n])
               for n in names]
        if self.table is not None:
            out.append((f"the table (top at z = {float(self.table.upper[2]):.6g} m)", self.table))
        if self.workspace is not None:
            out += workspace_slabs(*self.workspace)
        return out

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
    obj = SceneObject(str(name).lower(), kind, position, orientation)
    _body(obj, doc, where)
    return obj


def _positive(value, where: str, unit: str = "metres") -> float:
    out = number(value, where)
    if out <= 0.0:
        raise ValueError(f"{where}: expected a positive number ({unit}), got {describe(value)}")
    return out


def _body(obj: SceneObject, doc: dict, where: str) -> None:
    """The object's shape, size, travel, mass and friction, checked against one another (in place)."""
    shape = doc.get("shape")
    physical = [k for k in ("size", "travel", "mass", "friction") if doc.get(k) is not None]
    if shape is None and obj.type == "button" and obj.position is not None:
        shape = "button"  # every positioned button of a scene written before shapes existed is a button
    if shape is None:
        if physical:
            raise ValueError(f"{where}.{physical[0]}: expected it with a 'shape' (one of {list(SHAPES)}), "
                             "got no shape")
        return
    if not isinstance(shape, str) or shape not in SHAPES:
        raise ValueError(f"{where}.shape: expected one of {list(SHAPES)}, got {describe(shape)}")
    if obj.position is None:
        raise ValueError(f"{where}.shape: expected a 'position' with it (where the {shape} is), got none")
    parts = SHAPES[shape]
    size = doc.get("size")
    if size is None and shape != "button":
        raise ValueError(f"{where}.size: expected a {shape}'s [{', '.join(parts)}] (metres), got none")
    if size is not None:
        if not isinstance(size, (list, tuple)) or len(size) != len(parts):
            got = f"{len(size)} number(s)" if isinstance(size, (list, tuple)) else describe(size)
            raise ValueError(f"{where}.size: expected a {shape}'s [{', '.join(parts)}] ({len(parts)} "
                             f"number(s), metres), got {got}")
        size = [_positive(v, f"{where}.size[{k}]") for k, v in enumerate(size)]
    obj.shape = shape
    obj.size = np.array(BUTTON_SIZE if size is None else size, dtype=float)
    if doc.get("travel") is not None and shape != "button":
        raise ValueError(f"{where}.travel: expected travel on a button only (how far its cap moves), got it "
                         f"on a {shape}")
    if shape == "button":
        travel = doc.get("travel")
        obj.travel = BUTTON_TRAVEL if travel is None else _positive(travel, f"{where}.travel")
    if doc.get("mass") is not None:
        if shape == "button":
            raise ValueError(f"{where}.mass: expected mass on a movable body (box, cylinder, sphere), got it "
                             "on a button, which is fixed")
        obj.mass = _positive(doc["mass"], f"{where}.mass", "kilograms")
    if doc.get("friction") is not None:
        obj.friction = _positive(doc["friction"], f"{where}.friction", "a friction coefficient")


def _corners(value, where: str) -> tuple:
    if not isinstance(value, dict):
        raise ValueError(f"{where}: expected an object with 'lower' and 'upper' corners [x, y, z], got "
                         f"{describe(value)}")
    _unknown(value, ("lower", "upper"), where)
    for key in ("lower", "upper"):
        if value.get(key) is None:
            raise ValueError(f"{where}.{key}: expected a corner [x, y, z], got none")
    lower, upper = numbers(value["lower"], f"{where}.lower", 3), numbers(value["upper"], f"{where}.upper", 3)
    bad = np.flatnonzero(lower >= upper)
    if bad.size:
        k = int(bad[0])
        raise ValueError(f"{where}: expected lower < upper on every axis, got {'xyz'[k]}: lower "
                         f"{lower[k]:.6g} >= upper {upper[k]:.6g}")
    return lower, upper


def workspace_slabs(lower, upper) -> list:
    """``[(label, Box)]``: a slab :data:`WORKSPACE_SLAB` thick outside each face of the workspace box.

    Each reaches the slab's thickness past the other faces too, so a path leaving through an edge or a
    corner crosses one; a path that starts and ends inside the workspace leaves it only through a slab.
    """
    out, pad = [], WORKSPACE_SLAB
    for k, axis in enumerate("xyz"):
        for side, op in ((0, ">="), (1, "<=")):
            lo, hi = lower - pad, upper + pad
            if side == 0:
                hi = hi.copy()
                hi[k] = lower[k]
            else:
                lo = lo.copy()
                lo[k] = upper[k]
            bound = (lower, upper)[side][k]
            out.append((f"the workspace's bound {axis} {op} {bound:.6g} m", Box(lo, hi)))
    return out


def _table(value, workspace) -> Box:
    forms = "{\"height\": z} or {\"box\": [x0, y0, z0, x1, y1, z1]}"
    if not isinstance(value, dict):
        raise ValueError(f"table: expected {forms}, got {describe(value)}")
    _unknown(value, ("height", "box"), "table")
    if len(value) != 1:
        raise ValueError(f"table: expected {forms}, got {'both' if value else 'an empty object'}")
    if "height" in value:
        top = number(value["height"], "table.height")
        if workspace is None:
            lo, hi = np.full(2, -TABLE_HALF_EXTENT), np.full(2, TABLE_HALF_EXTENT)
        else:
            lo, hi = workspace[0][:2], workspace[1][:2]
        return Box([*lo, top - TABLE_THICKNESS], [*hi, top])
    corners = numbers(value["box"], "table.box", 6)
    bad = np.flatnonzero(corners[:3] >= corners[3:])
    if bad.size:
        k = int(bad[0])
        raise ValueError(f"table.box: expected x0 < x1, y0 < y1 and z0 < z1, got {'xyz'[k]}: "
                         f"{corners[k]:.6g} >= {corners[k + 3]:.6g}")
    return Box(corners[:3], corners[3:])


def _transit(value) -> float:
    if not isinstance(value, dict):
        raise ValueError(f"transit: expected {{\"height\": z}} (metres), got {describe(value)}")
    _unknown(value, ("height",), "transit")
    if value.get("height") is None:
        raise ValueError("transit.height: expected a height (metres), got none")
    return number(value["height"], "transit.height")


def _over_table(table, point) -> bool:
    """Whether ``point`` is within the table's footprint in x and y (so the table is under or over it)."""
    return bool(np.all(point[:2] >= table.lower[:2]) and np.all(point[:2] <= table.upper[:2]))


def _check_world(scene: Scene) -> None:
    """Objects and the start inside the workspace and not under the table top; a transit above the table."""
    table, workspace = scene.table, scene.workspace
    points = [("start.position", scene.start["position"])] if scene.start.get("position") is not None else []
    points += [(f"objects[{short(o.name)}].position", o.position) for o in scene.objects.values()
               if o.position is not None]
    for where, p in points:
        if workspace is not None:
            out = np.flatnonzero((p < workspace[0]) | (p > workspace[1]))
            if out.size:
                k = int(out[0])
                raise ValueError(f"{where}: expected a point inside the workspace, got {'xyz'[k]} = "
                                 f"{p[k]:.6g} outside [{workspace[0][k]:.6g}, {workspace[1][k]:.6g}]")
        if table is not None and _over_table(table, p) and p[2] < table.upper[2]:
            top = float(table.upper[2])
            if where == "start.position":
                raise ValueError(f"table: expected its top below the start's tool point, got the top at z = "
                                 f"{top:.6g} m above start.position z = {p[2]:.6g} m")
            raise ValueError(f"{where}: expected a point on or above the table top (z = {top:.6g} m), got "
                             f"z = {p[2]:.6g} m")
    if scene.transit is not None:
        if table is not None and scene.transit <= table.upper[2]:
            raise ValueError(f"transit.height: expected a height above the table top (z = "
                             f"{float(table.upper[2]):.6g} m), got {scene.transit:.6g} m")
        if workspace is not None and not workspace[0][2] < scene.transit <= workspace[1][2]:
            raise ValueError(f"transit.height: expected a height inside the workspace (z in "
                             f"[{workspace[0][2]:.6g}, {workspace[1][2]:.6g}]), got {scene.transit:.6g} m")


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


def scene_from_dict(doc, *, folder=None, need_goal: bool = True) -> Scene:
    """Check a parsed scene; ``folder`` is where its file lives (for ``domain``).

    With ``need_goal=False`` a scene may have no goal: a world to check and simulate a reuse in
    (``library reuse --scene``), not a task to plan.

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
    if need_goal and (doc.get("goal") is None or doc["goal"] == []):
        raise ValueError("goal: expected a non-empty list of atoms like '(pressed b1)', got "
                         f"{'none' if doc.get('goal') is None else 'an empty list'}")
    folder = None if folder is None else Path(folder)
    branch = doc.get("branch")
    if branch is not None and (not isinstance(branch, str) or not branch.strip()):
        raise ValueError(f"branch: expected the name of an inverse-kinematics branch like "
                         f"'shoulder-left/elbow-up/wrist-up', got {branch!r}")
    workspace = None if doc.get("workspace") is None else _corners(doc["workspace"], "workspace")
    scene = Scene(objects=objects, obstacles=obstacles, specs=specs,
                  init=_atoms(doc.get("init", []), "init", objects),
                  goal=_atoms([] if doc.get("goal") is None else doc["goal"], "goal", objects),
                  start=_start(doc.get("start", {})),
                  domain=None if doc.get("domain") is None else _confined(folder, doc["domain"], "domain"),
                  folder=folder, branch=branch, workspace=workspace,
                  table=None if doc.get("table") is None else _table(doc["table"], workspace),
                  transit=None if doc.get("transit") is None else _transit(doc["transit"]))
    _check_world(scene)
    return scene


def load_scene(path, *, need_goal: bool = True) -> Scene:
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
    return scene_from_dict(doc, folder=path.resolve().parent, need_goal=need_goal)
