"""``skillbank sim``: physics simulation. ``run`` replays a joint trajectory in a MuJoCo world of a scene
file (``_simulate``); ``record`` writes scripted demonstrations of a robosuite task in robomimic's HDF5
layout; ``evaluate`` runs a library's skills in new robosuite scenes and counts the environment's successes.

Exit status: ``run`` as ``_simulate`` says; ``record`` 0 when the file was written, 2 on bad input or when
too few episodes succeeded (nothing is written then); ``evaluate`` 0 when it ran (whatever the success
rate), 2 on bad input or when an episode's Dask workers all died (``--workers``, ``--scheduler``: no
report then).
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

from . import _simulate
from ._library_location import _DB_READ, _location, _target
from ._options import (
    EPISODES_DEFAULT,
    add_episode_options,
    add_verbose_option,
    check_folder,
    parallel_params,
    show_progress,
    verbose_logging,
)
from ._output import add_force_option

__all__ = ["add_parser"]


def add_parser(sub):
    """Register ``skillbank sim`` and its sub-commands ``run``, ``record`` and ``evaluate``.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="skillbank")
    >>> add_parser(parser.add_subparsers(dest="command"))  # doctest: +ELLIPSIS
    ArgumentParser(...)
    """
    p = sub.add_parser("sim", help="physics simulation (needs skillbank[sim]): run a trajectory in a "
                                   "scene file's MuJoCo world, record demonstrations of a robosuite task, "
                                   "evaluate a library's skills in robosuite",
                       description="Physics simulation (needs skillbank[sim]). 'run' replays a joint "
                                   "trajectory in the MuJoCo world of a scene FILE (--scene); 'record' "
                                   "writes demonstrations of a robosuite task (--env robosuite:TASK) that "
                                   "'library add' reads; 'evaluate' runs a library's skills in new scenes of "
                                   "a robosuite task and counts the environment's successes.")
    inner = p.add_subparsers(dest="sim_command", required=True)
    _simulate.add_run_parser(inner)
    r = inner.add_parser("record", help="record successful scripted demonstrations of a robosuite task on "
                                        "the UR5e (or --robot) into a robomimic HDF5 file (library add reads "
                                        "it)")
    r.add_argument("env_positional", nargs="?", default=None, metavar="robosuite:TASK",
                   help="the task, as --env (either one)")
    r.add_argument("--env", default=None, metavar="robosuite:TASK",
                   help="the task, e.g. robosuite:Lift or robosuite:Stack")
    r.add_argument("--episodes", type=int, default=EPISODES_DEFAULT,
                   help=f"successful episodes to keep (default {EPISODES_DEFAULT})")
    r.add_argument("--seed", type=int, default=0,
                   help="seeds the placements and the demonstrator (default 0)")
    r.add_argument("--max-tries", type=int, default=None,
                   help="episodes run at most (default 3 x --episodes); fewer successes write nothing")
    r.add_argument("--out", type=Path, required=True,
                   help="the HDF5 file to write (a new one, else --force), whole or not at all")
    add_force_option(r)
    r.add_argument("--robot", default="UR5e",
                   help="robosuite's arm: UR5e (default), Panda, Sawyer, IIWA, Jaco, Kinova3 or XArm7 (any "
                        "case: panda, ur5e), each with its default gripper")
    r.add_argument("--style", choices=("scripted", "human"), default="scripted",
                   help="scripted (default: smooth moves, robomimic's layout) or human (a person at a "
                        "keyboard: short pulses, pauses, overshoot, off-centre grasps, retries; robosuite's "
                        "raw collection format)")
    add_verbose_option(r)
    r.add_argument("--json", action="store_true",
                   help="print env, robot, episodes, tried, seed, out, samples as JSON")
    r.set_defaults(func=_record)
    e = inner.add_parser("evaluate", help="run a library's skills in new scenes of a robosuite task on one "
                                          "of its arms (--robot, default UR5e), closed loop, and count the "
                                          "environment's own successes")
    e.add_argument("db", type=_location, help=_DB_READ)
    e.add_argument("--env", required=True, metavar="robosuite:TASK", help="the task, e.g. robosuite:Lift")
    e.add_argument("--episodes", type=int, default=EPISODES_DEFAULT,
                   help=f"scenes to run (default {EPISODES_DEFAULT})")
    e.add_argument("--seed", type=int, default=0,
                   help="episode k is reset from seed SEED + k (robosuite's sampler places the objects)")
    e.add_argument("--placement", type=float, default=None, metavar="HALF_WIDTH",
                   help="widen every object's x and y placement range to +-HALF_WIDTH metres about its "
                        "default centre")
    e.add_argument("--method", default="lte",
                   help="how a primitive is adapted: lte (default), ja, promp, elmap or dmp; or a baseline, "
                        "rigid (the recorded segment moved rigidly into the object's new frame) or replay "
                        "(the source's actions, open loop)")
    e.add_argument("--planner", choices=["ompl", "none"], default="ompl",
                   help="free-space moves (the far part of a reach or a carry, a retreat after a release) "
                        "followed for the whole arm in the scene's MuJoCo geometry and, where a link, the "
                        "gripper or a held object would come near it, planned in joint space by OMPL's "
                        "RRTConnect ('ompl', default; skillbank[plan]); 'none' drives them as adapted")
    e.add_argument("--horizon", type=int, default=None,
                   help="control steps per episode (20 a second; default: what the library's longest "
                        "demonstration needs, its samples and the executor's waits, at least 1000)")
    e.add_argument("--robot", default="UR5e",
                   help="robosuite's arm that runs the skills, with its default gripper: UR5e (default), "
                        "Panda, Sawyer, IIWA, Jaco, Kinova3 or XArm7 (any case); a library recorded on "
                        "another arm runs through the tool's pose, with a note")
    e.add_argument("--order", type=lambda text: [o.strip() for o in text.split(",")], default=None,
                   metavar="OBJ,OBJ,...",
                   help="when the library's demonstrations each move other objects (one per object), the "
                        "order in which their parts run, by object name (default: the order the "
                        "demonstrations show them in)")
    e.add_argument("--json", action="store_true",
                   help="print env, robot, recorded_on, notes, episodes, successes, success_rate, interval "
                        "and per_episode as JSON (with --workers or --scheduler, scheduler too)")
    add_episode_options(e)  # --workers, --scheduler, -v
    e.set_defaults(func=_evaluate)
    return p


def _evaluate(args) -> int:
    from tqdm import tqdm  # core dependency; the bar only when asked

    from ..simulation import evaluate  # robosuite (the sim extra) is imported when the environment is made

    verbose_logging(args)
    with tqdm(total=args.episodes, desc="evaluating", unit="episode", file=sys.stderr,
              disable=not show_progress(args)) as bar:
        def tick(done, successes):
            bar.update(done - bar.n)
            bar.set_postfix_str(f"{successes} succeeded")

        report = evaluate(_target(args.db), args.env, episodes=args.episodes, seed=args.seed,
                          placement=args.placement, method=args.method, horizon=args.horizon,
                          order=args.order, progress=tick, robot=args.robot, verbose=args.verbose,
                          planner=args.planner, **parallel_params(args))
    if args.json:
        print(json.dumps(report))
        return 0
    low, high = report["interval"]
    print(f"{args.db}: {report['successes']} of {report['episodes']} episodes of {report['env']} succeeded "
          f"({100 * report['success_rate']:.0f} %, 95 % interval {100 * low:.0f}-{100 * high:.0f} %), "
          f"method {report['method']}, seeds {report['seed']}-{report['seed'] + report['episodes'] - 1}"
          + ("" if report["placement"] is None else f", placement +-{report['placement']} m")
          + f", on {report['robot']}")
    for note in report["notes"]:
        print(f"  note: {note}")
    for row in report["per_episode"]:
        if not row["success"]:
            f = row["failure"]
            print(f"  seed {row['seed']}: failed in segment {f['segment']} (primitive {f['primitive']}): "
                  f"{f['reason']}, {f['detail']}")
    timing = report["timing"]
    if timing["segments"]:
        print(f"  adapting took {1e3 * timing['adapt_seconds'] / timing['segments']:.1f} ms a segment, for "
              f"{timing['driven_seconds'] / timing['segments']:.2f} s of simulated motion")
    return 0


def _record(args) -> int:
    args.env = _task(args)
    check_folder(args.out, "out")  # record checks the task, the counts and the file before robosuite starts
    verbose_logging(args)
    # --force: written beside the old file and put in its place when whole (record never overwrites)
    final, args.out = args.out, args.out.with_name(f".{args.out.name}.{os.getpid()}.part{args.out.suffix}")
    try:
        report = _recorded(args)
        os.replace(args.out, final)
    finally:
        if os.path.lexists(args.out):
            os.unlink(args.out)
    args.out = final
    report["out"] = str(final)
    if args.json:
        print(json.dumps(report))
    else:
        print(f"{args.out}: {report['episodes']} successful episode(s) of {report['env']} "
              f"({report['tried']} tried, seed {report['seed']}) on {report['robot']}, {report['samples']} "
              "samples")
    return 0


def _task(args) -> str:
    """The task of ``sim record``: ``--env robosuite:TASK``, or the positional ``robosuite:TASK``."""
    given = {v for v in (args.env_positional, args.env) if v is not None}
    if not given:
        raise ValueError("env: expected the task, --env robosuite:TASK (e.g. robosuite:Lift)")
    if len(given) > 1:
        raise ValueError(f"env: the task is given twice, {args.env_positional!r} and --env {args.env!r}; "
                         "give it once")
    return given.pop()


def _recorded(args) -> dict:
    from tqdm import tqdm  # core dependency; the bar only when asked

    from ..simulation import record, record_human  # robosuite (the sim extra): when the environment is made

    with tqdm(total=args.episodes, desc="recording", unit="episode", file=sys.stderr,
              disable=not show_progress(args)) as bar:
        def tick(kept, tried):
            bar.update(kept - bar.n)
            bar.set_postfix_str(f"{tried} tried")

        if args.style == "human":
            report = record_human(args.env, episodes=args.episodes, out=args.out, seed=args.seed,
                                  max_tries=args.max_tries, progress=tick, robot=args.robot,
                                  verbose=args.verbose)
        else:
            report = record(args.env, episodes=args.episodes, out=args.out, seed=args.seed,
                            max_tries=args.max_tries, progress=tick, robot=args.robot)
    return report
