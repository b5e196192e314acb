"""Tasks never demonstrated, composed by a PDDL planner from labelled skills (issue 15's demonstrations).

Each task is written as its scene file, the PDDL domain and problem the
planner solved, the chained trajectory (CSV) and a figure:

``buttons`` (the three-button demonstration, ``data/seed``)
    The demonstration is segmented with the defaults; its two presses from
    one button to the next are labelled ``press`` and described by one PDDL
    action (the hand moves from where it is to a button and presses it, if
    the panel's code lets that button follow). The task: **four** buttons at
    new positions, pressed in the code's order b3, b1, b4, b2 (the
    demonstration pressed three, left to right), with a post between b1 and
    b4 that the unobstructed press would hit; on the UR5e, one continuous
    joint trajectory at most 1 rad/s per joint.
``rail_table`` (RAIL, ``data/rail``)
    Every RAIL reaching, pushing and pressing demonstration, stored whole and
    labelled with its class; each class described by an action. The goal
    names only the button (``(pressed run_button)``); the button works once
    the plate is loaded, so the planner pushes the cube onto the plate
    first. The cube, the plate and the button are at least 10 cm from any
    demonstration of their skill; the table (raised by a clearance) and a
    mug on the way to the button are obstacles. RAIL records positions
    only, so the plan is a path, with no robot.
``reach`` (embedded, no data)
    :func:`~skillbank.experiments.synthetic_ur5e`'s three moves labelled
    ``reach``: visit three targets, with a sphere between two of them, on
    the UR5e from given start joints.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from ..core import Demonstration
from ..io import atomic_output, load, load_rail, write_json, write_trajectory
from ..pipeline import Library
from ..planning import load_scene, write_pddl
from ..plotting import plot_plan
from ._demo import fresh_library, synthetic_ur5e

__all__ = ["run_planning_demo", "button_task", "rail_task", "reach_task", "button_scene", "rail_scene",
           "reach_scene", "PRESS_ACTION", "RAIL_ACTIONS", "REACH_ACTION"]

#: The three-button press: the hand moves from where it is (``?from``: the start or the button pressed
#: last) to the button ``?to`` and presses it, when the panel's code lets ``?to`` follow ``?from``.
PRESS_ACTION = """; press the button at ?to, the hand coming from ?from (the start or the last button pressed)
(:action press
  :parameters (?from ?to - spot)
  :precondition (and (hand-at ?from) (next ?from ?to))
  :effect (and (pressed ?to) (hand-at ?to) (not (hand-at ?from))))
"""

#: Four buttons (m, the UR5e's base frame) at new places on the demonstration's panel; the tool
#: orientation at each is the one recorded at the demonstration's first press.
BUTTONS = {"b1": [-0.25, -0.50, 0.12], "b2": [-0.05, -0.62, 0.10], "b3": [0.18, -0.50, 0.12],
           "b4": [0.34, -0.60, 0.11]}
BUTTON_CODE = ("b3", "b1", "b4", "b2")
BUTTON_ORIENTATION = [0.048, 0.962, -0.25, 0.095]
BUTTON_START = [-0.36, -0.42, 0.18]  # above the demonstration's first button, as it was after its reach
#: Between b1 and b4, on the path an unobstructed press takes; 2 cm in radius, which the whole UR5e (links
#: and gripper, 5 mm to spare) can pass.
BUTTON_POST = "sphere:0.116,-0.622,0.181,0.02"

#: The RAIL skills' actions, each named after its class (the label).
RAIL_ACTIONS = {
    "pushing": """; push the block ?x onto the target ?t (the hand meets the block at ?x and stops at ?t)
(:action pushing
  :parameters (?x - block ?t - target)
  :precondition (and (loose ?x) (empty ?t))
  :effect (and (on ?x ?t) (full ?t) (not (loose ?x)) (not (empty ?t))))
""",
    "pressing": """; press the button ?b of the machine at ?t; it works only with the target loaded
(:action pressing
  :parameters (?t - target ?b - button)
  :precondition (and (full ?t) (controls ?b ?t) (free ?b))
  :effect (and (pressed ?b) (not (free ?b))))
""",
    "reaching": """; reach down to the block ?x
(:action reaching
  :parameters (?x - block)
  :precondition (loose ?x)
  :effect (touched ?x))
""",
}
#: Each RAIL skill's binding: the parameter whose object the step ends at (two have two posed
#: parameters). RAIL's hand positions are contact points, and its pressing ends where the demonstrated
#: press did: no push past the button's top by its travel (offset 0).
RAIL_BINDINGS = {"pushing": {"goal": "?t"}, "pressing": {"goal": "?b", "offset": [0.0, 0.0, 0.0]},
                 "reaching": {"goal": "?x"}}
#: The table scene (m, RAIL's frame), as the hand's contact points. The plate is the push's goal;
#: the cube was placed where the push reproduced for it comes down onto the table, 8.5 cm before.
RAIL_OBJECTS = {"cube": ("block", [0.551, 0.315, 0.03]), "plate": ("target", [0.55, 0.40, 0.03]),
                "run_button": ("button", [0.52, -0.42, 0.06])}
RAIL_START = [0.40, 0.0, 0.35]
#: The table top raised by 1.5 cm of clearance (RAIL's hand rests 1 to 6 cm above z = 0), and a mug.
RAIL_OBSTACLES = {"table": "box:0.3,-0.55,-0.05,0.85,0.5,0.015", "mug": "sphere:0.608,-0.011,0.055,0.04"}

#: The embedded task's skill: move the tool to the target ``?p`` not yet visited.
REACH_ACTION = """; move the tool to the target ?p
(:action reach
  :parameters (?p - target)
  :precondition (unvisited ?p)
  :effect (and (visited ?p) (not (unvisited ?p))))
"""
REACH_TARGETS = {"t1": [-0.36, -0.26, 0.22], "t2": [-0.52, 0.02, 0.22], "t3": [-0.42, 0.2, 0.3]}
REACH_OBSTACLE = "sphere:-0.466,-0.116,0.225,0.03"


def _unit(q) -> list:
    q = np.asarray(q, dtype=float)
    return np.round(q / np.linalg.norm(q), 6).tolist()


def _obj(kind, position, orientation=None) -> dict:
    doc = {"type": kind, "position": [float(v) for v in position]}
    if orientation is not None:
        doc["orientation"] = _unit(orientation)
    return doc


def button_scene() -> dict:
    """The four-button scene: b1..b4 at :data:`BUTTONS`, the code :data:`BUTTON_CODE`, the post.

    Examples
    --------
    >>> doc = button_scene()
    >>> doc["init"]
    ['(hand-at home)', '(next home b3)', '(next b3 b1)', '(next b1 b4)', '(next b4 b2)']
    """
    objects = {"home": {"type": "spot"}}
    objects.update({n: _obj("spot", p, BUTTON_ORIENTATION) for n, p in BUTTONS.items()})
    code = ("home", *BUTTON_CODE)
    order = [f"(next {a} {b})" for a, b in zip(code[:-1], code[1:], strict=True)]
    return {"objects": objects, "obstacles": {"post": BUTTON_POST}, "init": ["(hand-at home)", *order],
            "goal": [f"(pressed {n})" for n in sorted(BUTTONS)],
            "start": {"position": BUTTON_START, "orientation": _unit(BUTTON_ORIENTATION)}}


def rail_scene() -> dict:
    """The RAIL table scene: a block to push onto the plate, whose button is the goal.

    Examples
    --------
    >>> rail_scene()["goal"]
    ['(pressed run_button)']
    """
    return {"objects": {n: _obj(k, p) for n, (k, p) in RAIL_OBJECTS.items()},
            "obstacles": dict(RAIL_OBSTACLES),
            "init": ["(loose cube)", "(empty plate)", "(free run_button)", "(controls run_button plate)"],
            "goal": ["(pressed run_button)"], "start": {"position": RAIL_START}}


def reach_scene(start_joints) -> dict:
    """The embedded scene: three targets to visit, tool pointing down, a sphere between t1 and t2.

    Examples
    --------
    >>> sorted(reach_scene([0.0] * 6)["objects"])
    ['t1', 't2', 't3']
    """
    down = [0.7071068, 0.7071068, 0.0, 0.0]
    return {"objects": {n: _obj("target", p, down) for n, p in REACH_TARGETS.items()},
            "obstacles": {"ball": REACH_OBSTACLE},
            "init": [f"(unvisited {n})" for n in REACH_TARGETS],
            "goal": [f"(visited {n})" for n in REACH_TARGETS],
            "start": {"joints": [float(v) for v in start_joints], "gripper": 0.0}}


def _button_library(lib, data: Path) -> None:
    """The three-button demonstration, segmented with the defaults; its presses labelled and described."""
    lib.add(load(data / "seed" / "three_button_pressing_demo.h5"), segment=True, assign="none",
            source="three_button_pressing_demo.h5")
    # the presses from one button to the next start and end down at a button (below 15 cm)
    presses = [p for p in lib.primitives() if p.demo["position"][[0, -1], 2].max() < 0.15]
    if len(presses) != 2:
        raise ValueError("data: expected the three-button demonstration to segment into two presses from "
                         f"one button to the next, got {len(presses)}")
    for p in presses:
        lib.label("press", primitive=p.id)
    lib.describe("press", PRESS_ACTION, {"goal": "?to"})


def _rail_library(lib, data: Path) -> int:
    """Every RAIL reaching, pushing and pressing demonstration, whole, labelled with its class; how many."""
    # positions only: RAIL's velocity and acceleration are derivatives of the recorded path, and an
    # edited path has its own (carried along, they would describe the demonstration, not the plan)
    demos = [Demonstration(d.t, {"position": d["position"]}, d.metadata)
             for d in load_rail(data / "rail", classes=list(RAIL_ACTIONS))]
    lib.add_many(demos, segment=False, assign="none", source="rail")
    for p in lib.primitives(load=False):
        lib.label(lib.demonstration(p.demonstration_id).metadata["label"], primitive=p.id)
    for label, action in RAIL_ACTIONS.items():
        lib.describe(label, action, RAIL_BINDINGS[label])
    return len(demos)


def _reach_library(lib, random_state) -> np.ndarray:
    """The synthetic UR5e recording, segmented, its moves labelled ``reach``; returns its first joints."""
    demo = synthetic_ur5e(random_state=random_state)
    lib.add(demo, label="reach", assign="none", source="synthetic-ur5e")
    # the gripper stays open: the recording closes it on its second move, which a visit does not need
    lib.describe("reach", REACH_ACTION, {"gripper": {"start": 0.0, "end": 0.0}})
    return demo["joints"][0]


def _nearest(point, prims) -> float:
    """Distance (m) from ``point`` to the nearest sample of any of the primitives (inf for none)."""
    return min((float(np.linalg.norm(p.demo["position"] - point, axis=1).min()) for p in prims),
               default=float("inf"))


def _library(out: Path, name: str) -> Library:
    path = out / f"{name}.sqlite"
    fresh_library(path)
    return Library(path)


def _command(lib, scene_path, robot, limits) -> str:
    """The same plan from the command line."""
    words = ["skillbank", "plan", str(lib.path), "--scene", str(scene_path)]
    if robot is not None:
        words += ["--robot", str(robot)]
    if limits and "joint_velocity" in limits:
        words += ["--max-joint-velocity", f"{limits['joint_velocity']:g}"]
    return " ".join(words)


def _task(lib, name, doc, out: Path, *, robot, limits, random_state, title) -> dict:
    """Plan ``doc`` with ``lib``'s skills; write the scene, PDDL, CSV and figure; the task's summary."""
    scene_path = out / f"{name}.scene.json"
    with atomic_output(scene_path) as tmp:  # whole; a link there is replaced, not written through
        tmp.write_text(json.dumps(doc, indent=2) + "\n")
    scene = load_scene(scene_path)
    t0 = time.perf_counter()
    res = lib.plan(scene, robot=robot, limits=limits, random_state=random_state)
    seconds = time.perf_counter() - t0
    domain, problem = write_pddl(res, out / name)
    csv = write_trajectory(res.trajectory, out / f"{name}.csv")
    prims = lib.primitives()
    used = {i for s in res.steps for i in s.used}
    figure = plot_plan(res, scene, out / f"{name}.png", demos={p.id: p.demo for p in prims if p.id in used},
                       title=title, unit="m")
    traj = res.trajectory
    P = traj["position"]
    steps = [{"action": s.action, "args": list(s.args), "skill": s.skill, "used": [int(i) for i in s.used],
              "samples": [int(s.start), int(s.stop)], "seconds": float(traj.t[s.stop - 1] - traj.t[s.start]),
              "goal": s.goal.tolist(), "end_error": float(np.linalg.norm(P[s.stop - 1] - s.goal)),
              "orientation_error": float(s.orientation_error), "notes": list(s.notes)} for s in res.steps]
    # how far each object is from where the skills acting on it were demonstrated
    acting = {}
    for s in res.steps:
        for a in s.args:
            acting.setdefault(a, set()).add(s.skill)
    objects = {n: {"type": o.type, "position": o.position.tolist(),
                   "nearest_demonstration": _nearest(o.position, [p for p in prims
                                                                  if p.label in acting.get(n, ())])}
               for n, o in scene.objects.items() if o.position is not None}
    labels = sorted({p.label for p in prims if p.label is not None})
    summary = {"task": name, "title": title, "plan": [[a, *args] for a, args in res.plan], "steps": steps,
               "objects": objects, "skills": {lab: sum(p.label == lab for p in prims) for lab in labels},
               "n_samples": int(traj.n_steps), "duration": float(traj.t[-1]), "streams": traj.stream_names,
               "collision": bool(res.collision),
               "clearance": {n: float(ob.signed_distance(P).min()) for n, ob in scene.obstacles.items()},
               "join_error": {k: float(v) for k, v in res.join_error.items()},
               "constraint_error": float(res.constraint_error),
               "robot": None if robot is None else str(robot),
               "notes": list(res.notes), "seconds": seconds,
               "files": {"scene": str(scene_path), "domain": str(domain), "problem": str(problem),
                         "trajectory": str(csv), "figure": str(figure), "library": str(lib.path)},
               "command": _command(lib, scene_path, robot, limits)}
    if "joints" in traj.streams:
        rates = np.abs(np.diff(traj["joints"], axis=0)) / np.diff(traj.t)[:, None]
        summary["peak_joint_velocity"] = float(rates.max())
        summary["whole_robot_clearance"] = None if res.clearance is None else float(res.clearance)
        summary["simulation"] = _physics(res, scene)
        summary["command"] += " --simulate"
    return summary


def simulated(trajectory, scene=None, targets=None):
    """``trajectory`` replayed in MuJoCo in ``scene`` (default an empty world), or None without the extra."""
    from ..planning import Scene  # the world's type
    from ..simulation import simulate  # the simulator's layer (MuJoCo, the sim extra, is imported in it)

    try:
        return simulate(trajectory, Scene(objects={}, obstacles={}, init=[], goal=[]) if scene is None
                        else scene, targets=targets)
    except ImportError:  # without skillbank[sim]: the summary says it was not simulated
        return None


def _physics(res, scene) -> dict | None:
    """What MuJoCo says of the plan (``SimulationResult.to_dict()`` and ``agree``), None without the extra."""
    sim = simulated(res.trajectory, scene, res.targets())
    return None if sim is None else {**sim.to_dict(), "agree": sim.confirmed}


def button_task(out, data, *, robot="ur5e", random_state=0) -> dict:
    """The four-button task from the three-button demonstration (see the module docstring).

    Writes ``buttons.sqlite`` (the library), ``buttons.scene.json``,
    ``buttons.domain.pddl``, ``buttons.problem.pddl``, ``buttons.csv`` (the
    chained trajectory) and ``buttons.png`` into ``out``.

    Parameters
    ----------
    out : str or path-like
    data : str or path-like
        The folder holding ``seed/three_button_pressing_demo.h5``.
    robot : str or None, default="ur5e"
        Joints by inverse kinematics, at most 1 rad/s; None: the path only.
    random_state : int, default=0

    Returns
    -------
    dict
        JSON-able: ``plan`` (``[action, *args]`` per step), ``steps`` (each
        with ``samples`` ``[start, stop]`` in the trajectory and its
        ``end_error`` to its goal, m), ``objects`` (each with its distance to
        the nearest demonstrated sample of the skills acting on it),
        ``collision``, ``clearance`` per obstacle (m), ``join_error``,
        ``files``, ``command`` (the same plan from the command line), ...

    Examples
    --------
    >>> import tempfile
    >>> item = button_task(tempfile.mkdtemp(), "data")  # doctest: +SKIP
    >>> item["plan"]  # doctest: +SKIP
    [['press', 'home', 'b3'], ['press', 'b3', 'b1'], ['press', 'b1', 'b4'], ['press', 'b4', 'b2']]
    """
    out, data = Path(out), Path(data)
    out.mkdir(parents=True, exist_ok=True)
    with _library(out, "buttons") as lib:
        _button_library(lib, data)
        item = _task(lib, "buttons", button_scene(), out, robot=robot,
                     limits=None if robot is None else {"joint_velocity": 1.0}, random_state=random_state,
                     title="Four new buttons, pressed in the code's order around a post, from two "
                           "demonstrated presses")
    item["demonstrated"] = ("three buttons pressed left to right, once (two presses from one button to "
                            "the next)")
    return item


def rail_task(out, data, *, random_state=0) -> dict:
    """The RAIL table task: push the cube onto the plate, then press its button (module docstring).

    Writes ``rail_table.*`` into ``out`` as :func:`button_task` does. RAIL
    records positions only, so the plan is a path, with no robot.

    Examples
    --------
    >>> import tempfile
    >>> rail_task(tempfile.mkdtemp(), "data")["plan"]  # doctest: +SKIP
    [['pushing', 'cube', 'plate'], ['pressing', 'plate', 'run_button']]
    """
    out, data = Path(out), Path(data)
    out.mkdir(parents=True, exist_ok=True)
    with _library(out, "rail_table") as lib:
        n = _rail_library(lib, data)
        item = _task(lib, "rail_table", rail_scene(), out, robot=None, limits=None, random_state=random_state,
                     title="RAIL skills: push the cube onto the plate, then press the button, around a mug")
    item["demonstrated"] = f"{n} RAIL demonstrations, each of one skill, none of them at these objects"
    return item


def reach_task(out, *, robot="ur5e", random_state=0) -> dict:
    """The embedded task: visit three targets with a synthetic UR5e recording's moves (module docstring).

    Writes ``reach.*`` into ``out`` as :func:`button_task` does; needs no data.

    Examples
    --------
    >>> import tempfile
    >>> item = reach_task(tempfile.mkdtemp())
    >>> item["plan"], item["collision"]
    ([['reach', 't1'], ['reach', 't2'], ['reach', 't3']], False)
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with _library(out, "reach") as lib:
        start = _reach_library(lib, random_state)
        item = _task(lib, "reach", reach_scene(start), out, robot=robot,
                     limits=None if robot is None else {"joint_velocity": 1.0}, random_state=random_state,
                     title="Three targets visited around a ball, from a synthetic UR5e recording's moves")
    item["demonstrated"] = "one recording of three moves (synthetic, embedded)"
    return item


def _markdown(result) -> str:
    lines = ["# Planning: tasks never demonstrated", "",
             "A PDDL planner orders labelled skills; each step is a reuse of its skill starting where the "
             "last one ended, chained into one trajectory. Reproduce any of them with its command.", ""]
    for name, item in result["tasks"].items():
        plan = ", ".join("(" + " ".join(step) + ")" for step in item["plan"])
        worst = max(s["end_error"] for s in item["steps"])
        clear = ", ".join(f"{k} {1000 * v:.1f} mm" for k, v in item["clearance"].items())
        collision = "**collides**" if item["collision"] else "no collision"
        lines += [f"## {name}", "", item["title"] + ".", "",
                  f"Demonstrated: {item['demonstrated']}. Plan: {plan}.", "",
                  f"{item['n_samples']} samples over {item['duration']:.2f} s; every step ends within "
                  f"{1000 * worst:.2g} mm of its goal; {collision} (clearance {clear}); gaps at the joins: "
                  + ", ".join(f"{k} {v:.2g}" for k, v in item["join_error"].items())
                  + (f"; peak joint speed {item['peak_joint_velocity']:.3g} rad/s"
                     if "peak_joint_velocity" in item else "") + ".", "",
                  *_physics_lines(item.get("simulation"), "simulation" in item),
                  f"`{item['command']}`", "", f"![{name}]({Path(item['files']['figure']).name})", ""]
    return "\n".join(lines)


def _physics_lines(sim, asked: bool) -> list:
    if not asked:
        return []
    if sim is None:
        return ["Not simulated: MuJoCo is not installed (pip install 'skillbank[sim]').", ""]
    facts = ", ".join(f"{k} {'cannot judge' if v is None else ('holds' if v else 'FAILS')}"
                      for k, v in sim["facts"].items())
    touched = ", ".join(f"{c['robot_body']} touched {c['other']} at {c['t']:.2f} s" for c in sim["contacts"])
    return [f"In MuJoCo ({sim['real_time_factor']:.0f}x real time): tool tracked within "
            f"{1000 * sim['tracking']['tool_max']:.2g} mm; {touched or 'no unintended contact'}; {facts}; "
            f"plan and physics {'agree' if sim['agree'] else 'do not agree'}.", ""]


def run_planning_demo(out, *, data=None, robot="ur5e", random_state=0) -> dict:
    """Plan and reproduce tasks never demonstrated; write each task's files, ``summary.md`` and ``.json``.

    Without ``data``: the embedded ``reach`` task. With ``data`` (the folder
    holding ``seed/`` and ``rail/``): the ``buttons`` and ``rail_table`` tasks
    too. See the module docstring for the tasks, :func:`button_task` for a
    task's files and summary.

    Parameters
    ----------
    out : str or path-like
        Output folder (created); each task's library in it is replaced.
    data : str or path-like, optional
    robot : str or None, default="ur5e"
        The robot of the ``buttons`` and ``reach`` tasks (None: paths only).
    random_state : int, default=0

    Returns
    -------
    dict
        JSON-able: ``out``, ``tasks`` (task name -> its summary),
        ``summary`` (summary.md), ``seconds``.

    Raises
    ------
    ValueError
        When ``data`` is not a folder with ``seed/`` and ``rail/``.

    Examples
    --------
    >>> import tempfile
    >>> res = run_planning_demo(tempfile.mkdtemp(), data="data")  # doctest: +SKIP
    >>> sorted(res["tasks"])  # doctest: +SKIP
    ['buttons', 'rail_table', 'reach']
    """
    t0 = time.perf_counter()
    out = Path(out)
    if data is not None:
        data = Path(data)
        if not (data / "rail").is_dir() or not (data / "seed").is_dir():
            raise ValueError(f"data: expected a folder with rail/ and seed/, got {str(data)!r}")
    out.mkdir(parents=True, exist_ok=True)
    tasks = {"reach": reach_task(out, robot=robot, random_state=random_state)}
    if data is not None:
        tasks["buttons"] = button_task(out, data, robot=robot, random_state=random_state)
        tasks["rail_table"] = rail_task(out, data, random_state=random_state)
    result = {"out": str(out), "tasks": tasks}
    path = out / "summary.md"
    with atomic_output(path) as tmp:
        tmp.write_text(_markdown(result))
    result["summary"] = str(path)
    result["seconds"] = time.perf_counter() - t0
    write_json(result, out / "summary.json")
    return result
