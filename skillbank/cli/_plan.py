"""``skillbank plan``: plan a task over the library's labelled skills and reproduce it as one trajectory."""

from __future__ import annotations

import json
import os
import shutil
from contextlib import contextmanager
from pathlib import Path

from ._execution_options import cli_robot
from ._library import check_robot, output_format, print_execution
from ._library_location import _DB_READ, _location, _target
from ._library_view import check_view, write_library_view
from ._options import (
    add_episode_options,
    add_export_options,
    add_robot_options,
    check_folder,
    export_params,
    parallel_params,
    robot_params,
    show_progress,
)
from ._output import add_force_option
from ._world import CLEARANCE_HELP, check_simulation, clearance_margin, print_simulation, run_simulation

__all__ = ["add_parser"]


def add_parser(sub):
    """Register ``skillbank plan``.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="skillbank")
    >>> add_parser(parser.add_subparsers(dest="command"))  # doctest: +ELLIPSIS
    ArgumentParser(...)
    """
    p = sub.add_parser("plan", help="plan a task over labelled skills (PDDL) and reproduce it as one "
                                    "trajectory (--search optimal needs skillbank[plan])")
    p.add_argument("db", type=_location, help=_DB_READ)
    p.add_argument("--scene", default=None, metavar="FILE",
                   help="scene file (JSON): objects with type/position/orientation, obstacles, init, goal, "
                        "start (see docs/planning.md); give it or --env")
    p.add_argument("--env", default=None, metavar="robosuite:TASK",
                   help="a robosuite task the plan is carried out in instead of a scene FILE, "
                        "robosuite:PickPlace or robosuite:Stack3 (with --simulate; see docs/simulation.md), "
                        "as 'sim evaluate --env'; '--scene robosuite:TASK' is the same")
    p.add_argument("--domain", type=Path, default=None,
                   help="a PDDL domain to use as it is (default: built from the skills' descriptions, see "
                        "'library describe')")
    add_robot_options(p, what="each step")  # --robot, --max-joint-velocity/-acceleration, --branch
    # one option, one meaning per scene kind: the shared help speaks of a kinematic model only, so plan's
    # --robot says what it names with a robosuite scene too
    robot = next(a for a in p._actions if a.dest == "robot")
    robot.metavar = "NAME|FILE|ARM"
    robot.help = (f"with a scene FILE: {robot.help}. With --scene robosuite:TASK: robosuite's arm that "
                  "carries the plan out, with its default gripper, as 'sim evaluate --robot': UR5e "
                  "(default), Panda, Sawyer, IIWA, Jaco, Kinova3, XArm7 (any case; no description FILE)")
    p.add_argument("--seed", type=int, default=None, help="random seed (for methods that sample)")
    p.add_argument("--max-groundings", type=int, default=None, metavar="N",
                   help="ground actions (an action bound to objects) the planner may build before it "
                        "searches (default 100000, checked before it starts)")
    p.add_argument("--time-limit", type=float, default=None, metavar="SECONDS",
                   help="seconds the planner may search before it gives up (default 600)")
    p.add_argument("--search", choices=["satisficing", "optimal"], default="satisficing",
                   help="the planner's search: 'satisficing' (default), skillbank's greedy best-first search "
                        "with the FF heuristic, which scales to hundreds of objects; 'optimal', A* with "
                        "LM-cut (jupyddl), the fewest steps, for small tasks")
    p.add_argument("--planner", choices=["ompl", "none"], default="ompl",
                   help="with --robot: a step whose skill (and transit) cannot keep the robot clear has its "
                        "move planned in joint space by OMPL's RRTConnect, every link, the gripper and the "
                        "scene checked ('ompl', default; skillbank[plan]); 'none' refuses such a step. In a "
                        "robosuite scene (--simulate): free-space moves are planned so in its MuJoCo "
                        "geometry where the adapted path would bring the arm near it; 'none' drives them "
                        "as adapted")
    p.add_argument("--motion-time-limit", type=float, default=None, metavar="SECONDS",
                   help="seconds the motion planner may search per transit (default 5)")
    p.add_argument("--out", type=Path, default=None,
                   help="write the trajectory with every stream (.csv, .npz, .script, .bag; see --format)")
    add_force_option(p)
    p.add_argument("--format", choices=["csv", "npz", "urscript", "rosbag"], default=None,
                   help="format of --out (default from its suffix)")
    add_export_options(p)
    p.add_argument("--plot", type=Path, default=None,
                   help="write a 3-D figure of the path coloured by step, with the scene's objects and "
                        "obstacles, and the PDDL files beside it (<plot>.domain.pddl, <plot>.problem.pddl)")
    p.add_argument("--view", type=Path, default=None, metavar="DIR",
                   help="write the library's web view to DIR with the plan's page (plan.html: the path by "
                        "step over the scene's objects and obstacles, joints, simulated contacts, buttons)")
    p.add_argument("--json", action="store_true",
                   help="print plan, steps (action, args, skill, start, stop, used), t, streams, collision, "
                        "constraint_error as JSON")
    p.add_argument("--clearance", type=float, default=None, metavar="METRES", help=CLEARANCE_HELP)
    p.add_argument("--simulate", action="store_true",
                   help="replay the plan's joints in a MuJoCo simulation of the scene (needs --robot and "
                        "skillbank[sim]) and report the planned and the achieved goal facts side by side; "
                        "exit 1 when they disagree or the robot touches what no step targets")
    g = p.add_argument_group("robosuite scenes (--env robosuite:TASK --simulate)")
    g.add_argument("--episodes", type=int, default=1,
                   help="scenes to plan and run; episode k is placed from seed --seed + k (default 1, seed "
                        "0: one plan carried out, as with a scene FILE; 'sim evaluate' and 'experiment', "
                        "which measure a success rate, run 10)")
    g.add_argument("--goal", default=None, metavar="FACTS",
                   help="the goal's facts, e.g. '(on cubeC cubeA) (on cubeA cubeB)' (default: the task's)")
    g.add_argument("--method", default="lte",
                   help="how each segment is adapted: lte (default), ja, promp, elmap, dmp; or replay (the "
                        "phases' recorded actions, open loop, in the planned order) or rigid")
    g.add_argument("--replan", action="store_true",
                   help="when a step's effect is not what the simulation shows, or what the plan expects no "
                        "longer holds, plan again from the observed facts (up to 3 times)")
    g.add_argument("--placement", type=float, default=None, metavar="HALF_WIDTH",
                   help="widen every object's x and y placement range to +-HALF_WIDTH metres")
    g.add_argument("--disturb", default=None, metavar="K:OBJECT:X,Y,Z",
                   help="after step K, put OBJECT at X,Y,Z (m): the world changing behind the plan's back")
    add_episode_options(p)  # --workers, --scheduler, -v: the robosuite episodes on Dask
    p.set_defaults(func=_plan)
    return p


def _plan(args) -> int:
    args.scene = _scene(args)
    if args.scene.startswith("robosuite:"):
        return _plan_physics(args)
    args.scene = Path(args.scene)
    if args.workers is not None or args.scheduler is not None:  # the episodes of a robosuite scene only
        given = "workers" if args.workers is not None else "scheduler"
        raise ValueError(f"--{given}: runs the episodes of a robosuite scene (--scene robosuite:TASK "
                         "--simulate) in parallel; leave it out")
    from .. import io  # the writers, only when a result is written
    from ..planning import load_scene, plan_task, write_pddl  # the planner's layers, when a plan runs
    from ..store import open_store  # the store, when a plan runs (not for --help)

    check_robot(args)
    check_simulation(args, "the plan's joints")
    limits, branch = (robot_params(args)[k] for k in ("limits", "branch"))
    kind = output_format(args)
    writing = export_params(args, kind)
    if args.plot is not None:
        from ..plotting import figure_path  # matplotlib only when a figure is asked for

        figure_path(args.plot, name="plot")  # a bad name fails before the work, not after
    for name in ("out", "plot"):
        check_folder(getattr(args, name), name)
    if args.view is not None:
        check_view(args.view)
    scene = load_scene(args.scene)
    if branch is not None:
        scene.branch = branch  # the command line's branch over the scene's
    if args.domain is not None and not args.domain.is_file():
        raise ValueError(f"domain: expected a PDDL domain file, got {str(args.domain)!r}, which is not "
                         "a file")
    with open_store(_target(args.db), create=False, readonly=True) as store:
        tick = None
        if show_progress(args):
            from tqdm import tqdm  # a bar on a terminal only

            bar = tqdm(desc="plan steps", unit="step")

            def tick(done, total):
                bar.total = total
                bar.update(done - bar.n)
        bound = {k: v for k, v in (("max_groundings", args.max_groundings), ("time_limit", args.time_limit))
                 if v is not None}
        if args.clearance is not None:
            bound["clearance"] = clearance_margin(args)
        result = plan_task(store, scene, domain=args.domain, robot=cli_robot(args), limits=limits,
                           random_state=args.seed, progress=tick, search=args.search, planner=args.planner,
                           motion_time_limit=args.motion_time_limit, **bound)
        prims = {p.id: p.demo for s in result.steps for p in store.primitives(label=s.skill)} \
            if args.plot is not None else {}
    if not result.plan:  # the goal already holds: a plan of no steps, and no trajectory to write
        return _empty(args, result, scene)
    # before anything is written: a world that refuses the plan (the robot starting in an obstacle)
    # leaves no output behind
    # each step may touch only the objects it acts on, while it acts on them
    sim = run_simulation(args, result.trajectory, scene, targets=result.targets()) if args.simulate else None
    with _all_or_nothing(args) as written:
        if args.out is not None:
            io.write_trajectory(result.trajectory, args.out, format=kind, **writing)
            written.append(args.out)
        if args.plot is not None:
            from ..plotting import plot_plan  # matplotlib only when a figure is asked for

            written += list(write_pddl(result, _stem(args.plot)))
            written.insert(0, plot_plan(result, scene, args.plot, demos=prims))
        if args.view is not None:  # last: a view that fails leaves no other output behind
            written.append(Path(_plan_view(args, result, scene, sim)["pages"]["plan.html"]))
    status = 0 if sim is None or sim.confirmed else 1
    if args.json:
        doc = result.to_dict()
        doc["planner"] = _planner(args)
        doc["written"] = [str(p) for p in written]
        if sim is not None:
            doc["robot"] = sim.robot  # the arm the simulation drove
            doc["simulation"] = sim.to_dict()
            doc["facts"] = {fact: {"planned": True, "achieved": value} for fact, value in sim.facts.items()}
            doc["agree"] = status == 0
        print(json.dumps(doc, allow_nan=False))
        return status
    print(f"{args.db}: plan of {len(result.plan)} step(s) for {len(scene.goal)} goal fact(s)")
    for k, s in enumerate(result.steps, 1):
        print(f"  {k}. ({' '.join([s.action, *s.args])}) by skill {s.skill!r} from primitive(s) {s.used}, "
              f"samples {s.start}:{s.stop}, ends {s.constraint_error:.3g} from its goal")
    joins = ", ".join(f"{k} {v:.3g}" for k, v in result.join_error.items())
    print(f"  joins: largest gap {joins}")
    traj = result.trajectory
    print_execution(traj, result.constraint_error, max(s.orientation_error for s in result.steps),
                    result.collision, traj.metadata.get("peaks", {}), result.notes,
                    orientation=any(s.goal_orientation is not None for s in result.steps))
    for path in written:
        print(f"  wrote {path}")
    if sim is not None:
        print_simulation(sim, planned=True)
    return status


def _scene(args) -> str:
    """``--scene FILE`` or ``--env robosuite:TASK`` (``--scene robosuite:TASK`` as before): exactly one."""
    if args.env is not None and args.scene is not None:
        raise ValueError(f"env: give --env {args.env} or --scene {args.scene}, not both")
    if args.env is None and args.scene is None:
        raise ValueError("scene: expected --scene FILE (a scene file) or --env robosuite:TASK")
    if args.env is not None and not args.env.startswith("robosuite:"):
        raise ValueError(f"env: expected robosuite:TASK (robosuite:PickPlace, robosuite:Stack3), got "
                         f"{args.env!r}; a scene file is --scene FILE")
    return args.env if args.env is not None else args.scene


def _plan_view(args, result, scene, sim) -> dict:
    """The library's web view with the plan's page, each step linked to its skill's page."""
    from ..plotting._view_result import plan_page  # the web view, only when one is asked for
    from ..store import open_store  # the store, as the plan opened it

    with open_store(_target(args.db), create=False, readonly=True) as store:
        version = store.current_version()
        labels = {} if version is None else store.cluster_labels(version)
    skills = {label: f"skill-{k}.html" for k, label in labels.items()}
    return write_library_view(args, {"plan.html": plan_page(result, scene, skills=skills, simulation=sim)})


def _planner(args) -> dict:
    """The ``planner`` entry of the JSON output: the search asked for and the planner that ran it."""
    from ..planning import SEARCHES  # the planner's layer, when a plan runs

    return {"search": args.search, "name": SEARCHES[args.search]}


def _stem(plot: Path) -> Path:
    return plot.with_suffix("") if plot.suffix else plot


@contextmanager
def _all_or_nothing(args):
    """Outputs are written all or not at all: a failure part-way removes those this command created."""
    targets = [] if args.out is None else [Path(args.out)]
    if args.plot is not None:
        from ..plotting import figure_path  # matplotlib only when a figure is asked for

        stem = _stem(args.plot)
        targets += [figure_path(args.plot, name="plot"), stem.with_name(stem.name + ".domain.pddl"),
                    stem.with_name(stem.name + ".problem.pddl")]
    new = [p for p in targets if not os.path.lexists(p)]
    try:
        yield []
    except BaseException:
        for path in new:
            if path.is_dir() and not path.is_symlink():
                shutil.rmtree(path, ignore_errors=True)  # a ROS 2 bag is a folder
            elif os.path.lexists(path):
                path.unlink()
        raise


def _empty(args, result, scene) -> int:
    """Report a plan of no steps (exit 0): nothing is reproduced, so --out and --plot write nothing."""
    notes = list(result.notes)
    asked = [f"--{name}" for name in ("out", "plot", "view") if getattr(args, name) is not None]
    if asked:
        notes.append(f"{' and '.join(asked)}: nothing written (a plan of no steps has no trajectory)")
    if args.simulate:
        notes.append("--simulate: nothing simulated (a plan of no steps moves nothing)")
    if args.json:
        doc = result.to_dict()
        doc.update(notes=notes, written=[], planner=_planner(args))
        print(json.dumps(doc, allow_nan=False))
        return 0
    print(f"{args.db}: plan of 0 step(s) for {len(scene.goal)} goal fact(s)")
    for note in notes:
        print(f"  note: {note}")
    return 0


def _disturbance(text):
    parts = text.split(":")
    try:
        after, obj, xyz = int(parts[0]), parts[1], [float(v) for v in parts[2].split(",")]
    except (ValueError, IndexError):
        raise ValueError(f"disturb: expected K:OBJECT:X,Y,Z (a step number, an object, metres), got "
                         f"{text!r}") from None
    if len(parts) != 3 or len(xyz) != 3:
        raise ValueError(f"disturb: expected K:OBJECT:X,Y,Z (a step number, an object, metres), got {text!r}")
    return {"after": after, "object": obj, "position": xyz}


def _robosuite_arm(name) -> str:
    """``--robot`` with a robosuite scene: robosuite's arm (its spelling), default the UR5e; a
    description file, which names a kinematic model for skillbank's own scenes, is refused."""
    from ..simulation._evaluate import DRIVEN_ROBOT  # robosuite's names, when a plan runs
    from ..simulation._robosuite import robosuite_robot  # the same, as sim evaluate checks them

    if name is None:
        return DRIVEN_ROBOT
    if Path(name).suffix.lower() in (".urdf", ".xml", ".mjcf") or Path(name).is_file():
        raise ValueError(f"robot: with a robosuite scene --robot names robosuite's arm that carries the plan "
                         f"out (UR5e, Panda, Sawyer, IIWA, Jaco, Kinova3, XArm7), not a description file "
                         f"({name!r}); a description is for a scene FILE")
    return robosuite_robot(name)


def _plan_physics(args) -> int:
    """``plan LIB --scene robosuite:TASK --simulate``: plan over the described skills and carry it out."""
    import re

    from ..simulation import execute_plan  # robosuite and the planner, when a plan runs

    # what a kinematic model or a written trajectory needs: robosuite's controller drives its own arm
    kinematic = ("out", "format", "domain", "clearance", "motion_time_limit", "view", "tool_frame", "tool",
                 "robot_base", "branch", "max_joint_velocity", "max_joint_acceleration")
    given = [f"--{n.replace('_', '-')}" for n in kinematic if getattr(args, n, None) is not None]
    if given:
        raise ValueError(f"{given[0]}: a robosuite scene runs robosuite's arm (--robot) in its own world, "
                         "with its own controller, and writes no trajectory; leave it out")
    robot = _robosuite_arm(args.robot)
    if not args.simulate:
        raise ValueError(f"scene: {args.scene} is a robosuite task: its plan is carried out in the "
                         "simulation; add --simulate")
    if args.plot is not None:
        from ..plotting import figure_path  # matplotlib only when a figure is asked for

        figure_path(args.plot, name="plot")
        check_folder(args.plot, "plot")
    goal = None if args.goal is None else re.findall(r"\([^()]*\)", args.goal)
    if args.goal is not None and (not goal or re.sub(r"\([^()]*\)", "", args.goal).strip()):
        raise ValueError(f"goal: expected facts such as '(on cubeA cubeB) (on cubeB cubeC)', got "
                         f"{args.goal!r}")
    disturb = None if args.disturb is None else _disturbance(args.disturb)
    progress = None
    if show_progress(args):
        from tqdm import tqdm  # a bar on a terminal only

        bar = tqdm(total=args.episodes, desc="episodes", unit="episode")

        def progress(done, successes):
            bar.update(done - bar.n)
            bar.set_postfix(successes=successes)
    report = execute_plan(_target(args.db), args.scene, episodes=args.episodes,
                          seed=0 if args.seed is None else args.seed, goal=goal, method=args.method,
                          replan=args.replan, placement=args.placement, disturb=disturb, search=args.search,
                          paths=args.plot is not None, progress=progress, robot=robot, verbose=args.verbose,
                          planner=args.planner, **parallel_params(args))
    written = []
    if args.plot is not None:
        from ..plotting import plot_composed  # matplotlib only when a figure is asked for

        written.append(str(plot_composed(report["per_episode"][0], args.plot, title=f"{args.scene}, seed "
                                         f"{report['per_episode'][0]['seed']}, {report['method']}")))
        for row in report["per_episode"]:
            row.pop("path", None)
    status = 0 if report["successes"] == report["episodes"] else 1
    if args.json:
        print(json.dumps({**report, "planner": _planner(args), "written": written}, allow_nan=False))
        return status
    for row in report["per_episode"]:
        print(f"{args.scene} seed {row['seed']}: plan of {len(row['plan'])} step(s): {' '.join(row['plan'])}")
        for st in row["steps"]:
            seen = st.get("observed", {}).get("facts", [])
            head = f"  {st['step']}. ({' '.join([st['action'], *st['args']])})"
            if st["ok"]:
                print(f"{head} by demonstration {st['source']}, primitives {st['primitives']}: planned "
                      f"{' '.join(st['planned']['add'])}, seen {' '.join(seen)}")
            else:
                print(f"{head}: {st['reason']}: {st['detail']}")
            if "replanned" in st:
                print(f"     replanned: {' '.join(st['replanned']) or '(no steps)'}")
        verdict = "success" if row["success"] else f"failure ({row['failure']['reason']})"
        # the order carried out: the moves the goal leaves free are taken tallest first, not as planned
        done = " ".join(f"({' '.join([s['action'], *s['args']])})" for s in row["steps"] if s["ok"])
        print(f"  carried out: {done or '(no steps)'}")
        print(f"  {verdict} by the environment's check, {row['control_steps']} control steps")
    lo, hi = report["interval"]
    print(f"{args.scene}: {report['successes']}/{report['episodes']} = {100 * report['success_rate']:.0f} % "
          f"[{100 * lo:.1f}, {100 * hi:.1f}] (Wilson 95 %), method {report['method']}, on {report['robot']}")
    for note in report["notes"]:
        print(f"  note: {note}")
    if report["failures"]:
        print("  failures: " + ", ".join(f"{k} {v}" for k, v in sorted(report["failures"].items())))
    for path in written:
        print(f"  wrote {path}")
    return status

