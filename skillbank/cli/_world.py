"""The world a reuse or an edit is checked and simulated in: ``--scene``, ``--simulate``.

``library reuse`` and ``edit`` take a scene file as their world (its obstacles, table and workspace
bound the tool path as ``--obstacle`` does; a goal is not needed) and ``--simulate`` replays the
result's joints in MuJoCo. ``plan`` has its own ``--scene`` (the task) and shares the simulation's
report from here.
"""

from __future__ import annotations

from ._options import show_progress

__all__ = ["add_world_options", "check_simulation", "load_world", "world_constraints", "run_simulation",
           "print_simulation", "whole_robot", "print_clearance", "clearance_margin", "CLEARANCE_HELP"]

CLEARANCE_HELP = ("with --robot: the distance every body of the robot (links, gripper) keeps from the "
                  "obstacles, the table, the workspace bounds and itself (default 0.005, beyond its "
                  "capsules, which already envelop the links)")


def add_world_options(p) -> None:
    """``--scene`` (a world) and ``--simulate`` for the commands that make one executable trajectory."""
    from pathlib import Path  # stdlib

    p.add_argument("--scene", type=Path, default=None, metavar="FILE",
                   help="a scene file (JSON, docs/planning.md) as the world: its obstacles, table and "
                        "workspace bound the path like --obstacle; its buttons and objects are simulated "
                        "with --simulate; its goal facts, if any, are judged there")
    p.add_argument("--clearance", type=float, default=None, metavar="METRES",
                   help=CLEARANCE_HELP.replace("and itself", "(a reproduction that comes closer is repaired "
                                               "with via points, or refused)"))
    p.add_argument("--simulate", action="store_true",
                   help="replay the result's joints in a MuJoCo simulation of the world (needs --robot "
                        "and skillbank[sim]); exit 1 when the robot touches anything but the scene's "
                        "buttons and objects or a goal fact fails")


def clearance_margin(args):
    """``--clearance`` checked (metres, >= 0; needs ``--robot``), or None for the default."""
    value = getattr(args, "clearance", None)
    if value is None:
        return None
    if getattr(args, "robot", None) is None:
        raise ValueError("clearance: the whole robot's clearance needs joints: give --robot too")
    from ..core._validation import check_positive  # numpy only

    return check_positive(value, name="clearance", allow_zero=True)


def check_simulation(args, what: str = "joints") -> None:
    """With ``--simulate``: a robot and the extra, checked before the work (a simulation replays ``what``)."""
    if not getattr(args, "simulate", False):
        return
    if getattr(args, "robot", None) is None:
        raise ValueError(f"simulate: a simulation replays {what}: give --robot too (--robot ur5e)")
    from ..simulation import import_mujoco  # the extra is checked before the work, not after

    import_mujoco()


def load_world(args):
    """The ``--scene`` world (a :class:`~skillbank.planning.Scene`, goal optional) or None, checked first."""
    check_simulation(args)
    if getattr(args, "scene", None) is None:
        return None
    from ..planning import load_scene  # scene files, when one is given

    return load_scene(args.scene, need_goal=False)


def world_constraints(constraints, scene):
    """``constraints`` with the world's obstacles, table and workspace slabs added (the tool stays out)."""
    if scene is None:
        return constraints
    return constraints.replace(obstacles=tuple(constraints.obstacles) + tuple(ob for _, ob in scene.world()))


def whole_robot(args, trajectory, scene, obstacles):
    """The whole robot's clearance along ``trajectory``'s joints (None without --robot or joints).

    ``obstacles``: the command's own (``--obstacle``); the scene's obstacles, table and workspace are
    added with their roles (the base stands on the table).
    """
    if getattr(args, "robot", None) is None or "joints" not in trajectory.streams:
        return None
    from ..robots import clearance  # numpy only
    from ._execution_options import cli_robot  # the one place --robot becomes a model

    named = {f"obstacles[{k}]": ob for k, ob in enumerate(obstacles)}
    table = workspace = None
    if scene is not None:
        named.update(scene.obstacles)
        table, workspace = scene.table, scene.workspace
    return clearance(cli_robot(args), trajectory["joints"], named, table=table, workspace=workspace,
                     t=trajectory.t)


def print_clearance(res) -> None:
    where = "" if res.time is None else f" at t = {res.time:.4g} s"
    state = "TOUCHES" if res.min_distance < 0 else "clear"
    print(f"  whole robot {state}: {res.min_distance * 1000:.3g} mm between its {res.body} and "
          f"{res.other}{where}")


def run_simulation(args, trajectory, scene, obstacles=(), *, targets=None, video=None):
    """Replay ``trajectory`` in ``scene`` with the command's own ``obstacles`` (``--obstacle``) added.

    ``targets`` and ``video`` as :func:`skillbank.simulation.simulate` takes them; a tqdm bar of the
    physics steps on a terminal.
    """
    import dataclasses  # stdlib

    from ..planning import Scene  # the world's type
    from ..simulation import simulate  # the simulator's layer (MuJoCo is imported inside it)
    from ._execution_options import cli_robot  # the one place --robot becomes a model

    own = {f"obstacles[{k}]": ob for k, ob in enumerate(obstacles)}
    if scene is None:
        scene = Scene(objects={}, obstacles=own, init=[], goal=[],
                      specs={k: ob.spec() for k, ob in own.items()})
    elif own:
        scene = dataclasses.replace(scene, obstacles={**scene.obstacles, **own},
                                    specs={**scene.specs, **{k: ob.spec() for k, ob in own.items()}})
    bar = None
    if show_progress(args):
        from tqdm import tqdm  # a bar on a terminal only

        bar = tqdm(desc="physics steps", unit="step", leave=False)
    try:
        return simulate(trajectory, scene, robot=cli_robot(args), targets=targets, progress=bar, video=video)
    finally:
        if bar is not None:
            bar.close()


def print_simulation(sim, *, planned: bool = False) -> None:
    """The simulation's report under a command's own (two-space indent)."""
    print(f"  simulated {sim.duration:.3g} s on {sim.robot} at {sim.real_time_factor:.3g}x real time: "
          f"tracking within {sim.joint_max:.3g} rad, tool within {sim.tool_max * 1000:.3g} mm")
    for fact, value in sim.facts.items():
        seen = "cannot judge" if value is None else ("holds" if value else "FAILS")
        print(f"    {fact}: {'planned holds, ' if planned else ''}simulated {seen}")
    for name, b in sim.buttons.items():
        when = f"pressed at {b['t']:.3f} s" if b["pressed"] else "not pressed"
        print(f"    button {name}: {when}, peak force {b['peak_force']:.3g} N")
    for name, o in sim.objects.items():
        held, lifted = ("held" if o["held"] else "not held"), ("lifted" if o["lifted"] else "not lifted")
        print(f"    object {name}: moved {o['displacement'] * 1000:.3g} mm, {held}, {lifted}")
    for c in sim.contacts:
        print(f"    contact {c['t']:.3f} s: {c['robot_body']} touched {c['other']}, peak {c['force']:.3g} N")
    if planned:
        print(f"  plan and simulation {'agree' if sim.confirmed else 'DISAGREE'}")
    else:
        print(f"  simulation {'ok' if sim.confirmed else 'NOT ok'}")
