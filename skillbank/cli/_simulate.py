"""``skillbank sim run``: replay a joint trajectory in a MuJoCo world of a scene and report what happened.

``skillbank simulate`` is its old name, kept as an alias that says so on stderr.

Exit status: 0 when every goal fact the simulation can judge holds and no unintended contact happened,
1 otherwise, 2 on bad input (docs/simulation.md).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from ._execution_options import ROBOT_HELP, add_tool_frame_option
from ._library import check_robot
from ._options import check_folder
from ._world import run_simulation

__all__ = ["add_parser", "add_run_parser", "DEPRECATED"]

#: What ``skillbank simulate`` says on stderr before it runs as ``sim run``.
DEPRECATED = "skillbank simulate: deprecated, use 'skillbank sim run' (the same options)"

_RUN_HELP = ("replay a joint trajectory (a reuse's or plan's output) in a MuJoCo simulation of a scene FILE "
             "(needs skillbank[sim]); exit 1 when a goal fact fails or the robot touches what it should not")


def add_parser(sub):
    """Register ``skillbank simulate``, the old name of ``skillbank sim run`` (:func:`add_run_parser`).

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="skillbank")
    >>> add_parser(parser.add_subparsers(dest="command"))  # doctest: +ELLIPSIS
    ArgumentParser(...)
    """
    p = sub.add_parser("simulate", help="deprecated: the old name of 'sim run', which it runs")
    _add_arguments(p)
    p.set_defaults(func=_deprecated)
    return p


def add_run_parser(sub):
    """Register ``run`` on the sub-commands ``sub`` of ``skillbank sim``."""
    p = sub.add_parser("run", help=_RUN_HELP)
    _add_arguments(p)
    p.set_defaults(func=_simulate)
    return p


def _deprecated(args) -> int:
    print(DEPRECATED, file=sys.stderr)
    return _simulate(args)


def _add_arguments(p) -> None:
    p.add_argument("trajectory", type=Path,
                   help="a file with a 'joints' stream: a reuse's or plan's CSV or NPZ, or a recording "
                        "such as the three-button HDF5")
    p.add_argument("--scene", type=Path, required=True,
                   help="scene file (JSON): table, obstacles, buttons, objects, goal "
                        "(see docs/simulation.md)")
    p.add_argument("--robot", default="ur5e", metavar="NAME|FILE",
                   help=f"the robot: {ROBOT_HELP}; default ur5e")
    add_tool_frame_option(p)
    p.add_argument("--json", action="store_true",
                   help="print duration, real_time_factor, tracking, contacts, buttons, objects, facts, "
                        "notes as JSON")
    p.add_argument("--plot", type=Path, default=None,
                   help="write a figure: the tool path with contacts marked, and each button's force "
                        "over time")
    p.add_argument("--video", type=Path, default=None,
                   help="write an animated GIF rendered off-screen (EGL or OSMesa)")


def _simulate(args) -> int:
    from .. import io  # the readers, when a trajectory is read
    from ..planning import load_scene  # scene files, when a simulation runs

    check_robot(args)
    if args.plot is not None:
        from ..plotting import figure_path  # matplotlib only when a figure is asked for

        figure_path(args.plot, name="plot")
    for name in ("plot", "video"):
        check_folder(getattr(args, name), name)
    io.check_input_file(args.trajectory, name="trajectory")
    scene = load_scene(args.scene)
    demo = io.load(args.trajectory)
    result = run_simulation(args, demo, scene, video=args.video)
    written = []
    if args.plot is not None:
        from ..plotting import plot_simulation  # matplotlib only when a figure is asked for

        written.append(plot_simulation(result, scene, args.plot, title=str(args.trajectory.name)))
    if result.video_ is not None:
        written.insert(0, result.video_)
    status = 0 if result.ok else 1
    if args.json:
        doc = result.to_dict()
        doc["written"] = [str(p) for p in written]
        print(json.dumps(doc, allow_nan=False))
        return status
    _report(args, result, written)
    return status


def _report(args, result, written) -> None:
    print(f"{args.trajectory}: simulated {result.duration:.3g} s on {result.robot} at "
          f"{result.real_time_factor:.3g}x real time; {'ok' if result.ok else 'NOT ok'}")
    print(f"  tracking: joints within {result.joint_max:.3g} rad, tool within "
          f"{result.tool_max * 1000:.3g} mm")
    if result.contacts:
        print(f"  contacts ({len(result.contacts)} unintended):")
        for c in result.contacts:
            print(f"    {c['t']:.3f} s  {c['robot_body']} touched {c['other']}, peak {c['force']:.3g} N")
    else:
        print("  contacts: none unintended")
    from ..simulation import PRESS_FORCE  # the force run_simulation's buttons need

    for name, b in result.buttons.items():
        when = f"at {b['t']:.3f} s" if b["pressed"] else "never"
        # a spring pushes back 1.5 x the press force at full travel; a peak past that is the end stop's
        stop = 1.5 * PRESS_FORCE
        why = f" (needs {PRESS_FORCE:.3g} N; past {stop:.3g} N the tool pushes it against its end stop)" \
            if b["peak_force"] > stop else ""
        print(f"  button {name}: {'pressed' if b['pressed'] else 'not pressed'} ({when}), peak force "
              f"{b['peak_force']:.3g} N{why}")
    for name, o in result.objects.items():
        held = "held" if o["held"] else "not held"
        print(f"  object {name}: moved {o['displacement'] * 1000:.3g} mm, {held}, "
              f"{'lifted' if o['lifted'] else 'not lifted'}")
    for fact, value in result.facts.items():
        print(f"  fact {fact}: {'cannot judge' if value is None else ('holds' if value else 'FAILS')}")
    for note in result.notes:
        print(f"  note: {note}")
    for path in written:
        print(f"  wrote {path}")
