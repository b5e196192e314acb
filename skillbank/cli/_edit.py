"""``skillbank edit``: adapt a demonstration to new constraints with LTE or an LfD representation."""

from __future__ import annotations

import json
from pathlib import Path

from ..core import Demonstration
from ._library import check_robot, output_format, print_execution
from ._options import (
    add_constraint_options,
    add_execution_options,
    add_pose_of_option,
    add_repair_option,
    constraints_from_args,
    execution_params,
    export_params,
)
from ._output import add_force_option
from ._world import (
    clearance_margin,
    load_world,
    print_clearance,
    print_simulation,
    run_simulation,
    whole_robot,
    world_constraints,
)

__all__ = ["add_parser", "run"]


def add_parser(sub):
    """Register ``edit`` on argparse subparsers ``sub``.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="skillbank")
    >>> add_parser(parser.add_subparsers(dest="command"))  # doctest: +ELLIPSIS
    ArgumentParser(...)
    """
    p = sub.add_parser("edit", help="adapt a demonstration to a new start, goal, via-points and obstacles")
    p.add_argument("input", nargs="+", type=Path,
                   help="trajectory file(s) (.csv, .npz, .h5, .mat); several for the multi-demo methods "
                        "(promp, elmap, dmp). The 'position' stream is edited, or the only stream; the first "
                        "file's orientation, gripper and other streams come along")
    p.add_argument("--method", default="lte",
                   help="a representation of skillbank.representations.REPRESENTATIONS: lte (Laplacian "
                        "trajectory editing, default, as 'sim evaluate', 'plan' and 'experiment', which "
                        "adapt one demonstration each), ja (jerk-accuracy), promp, elmap (elastic map), "
                        "dmp; 'library reuse' defaults to promp, which learns from its several candidates")
    add_constraint_options(p)
    p.add_argument("--metrics", action="store_true",
                   help="also compare the result with the demonstration (Fréchet, DTW, swept area, ...); "
                        "Fréchet and DTW take time proportional to the product of the lengths")
    add_execution_options(p)
    add_pose_of_option(p)
    p.add_argument("--out", type=Path, default=None,
                   help="write the result with every stream (.csv, .npz, .script, .bag; see --format)")
    add_force_option(p)
    add_repair_option(p)
    p.add_argument("--json", action="store_true",
                   help="print the result as JSON: t, streams, joint_names, trajectory (the position path), "
                        "used, rejected, constraint_error, orientation_error, collision, peak_joint_velocity")
    p.add_argument("--plot", type=Path, default=None,
                   help="write a figure of the edit to this file (.png, .pdf, .svg; no extension: .png)")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    """Edit ``args.input`` under the constraints given on the command line; returns the exit status."""
    # Imported here, not at the top, so that 'skillbank --help' and the other commands start
    # without scikit-learn and scipy.
    from ..io import load_positions, write_trajectory
    from ..metrics import comparison_metrics
    from ..representations import fit_reproduce, representation
    from ..robots import CLEARANCE
    from ..selection import executable_dict, keep_clear, make_executable, retime

    representation(args.method)  # an unknown name fails first, listing the registry's
    constraints = constraints_from_args(args.start, args.goal, args.via, args.obstacle,
                                        start_orientation=args.start_orientation,
                                        goal_orientation=args.goal_orientation,
                                        via_orientation=args.via_orientation)
    execution = execution_params(args)
    check_robot(args)
    margin = clearance_margin(args)
    if margin is None:
        margin = CLEARANCE
    world = load_world(args)
    own = tuple(constraints.obstacles)
    constraints = world_constraints(constraints, world)
    kind = output_format(args)
    writing = export_params(args, kind, execution["duration"])
    if args.plot is not None:
        from ..plotting import figure_path  # matplotlib only when a figure is asked for

        figure_path(args.plot, name="plot")  # a bad name fails before the work, not after
    read = load_positions(args.input, repair_time=args.repair_time, every_stream=True, pose_of=args.pose_of)
    converted = []
    if execution["robot"] is not None:
        from ..robots import to_tool  # numpy only

        # the constraints are the robot tool's: each file's poses become its tool's before the edit
        for k, (d, p) in enumerate(zip(read, args.input, strict=True)):
            read[k], more = to_tool(d, execution["robot"], what=f"file {str(p)!r}")
            converted += [n for n in more if n not in converted]
    sources = [retime(d, execution["duration"]) for d in read]
    demos = [Demonstration(d.t, {"position": d["position"]}, {"source": str(p)})
             for d, p in zip(sources, args.input, strict=True)]
    constraints.check_dims(demos[0]["position"].shape[1])
    meta = {"method": args.method, "inputs": [str(p) for p in args.input]}

    def make(task):
        out, collision, notes = fit_reproduce(args.method, demos, task)
        done = make_executable(Demonstration(out.t - out.t[0], {"position": out["position"]}, dict(meta)),
                               sources, task, ids=[Path(p).name for p in args.input],
                               robot=execution["robot"], limits=execution["limits"], kind="file",
                               branch=execution["branch"], clearance_margin=margin)
        return (collision, notes, done), done.trajectory

    if execution["robot"] is None:
        (collision, notes, done), _ = make(constraints)
    else:
        # every moving body keeps the margin from the obstacles: repaired with via points, or refused
        kept = keep_clear(make, constraints, execution["robot"], margin=margin)
        if kept.reason is not None:
            raise ValueError(f"edit: {kept.reason}; nothing was written")
        (collision, notes, done), constraints = kept.result, kept.constraints
        notes = notes + kept.notes
    done.notes[:0] = converted
    traj = done.trajectory
    Y, t = traj["position"], traj.t
    error = constraints.position_error(Y)
    metrics = comparison_metrics(Y, t, demos[0]["position"], constraints) if args.metrics else None
    traj.metadata.update(constraint_error=error, orientation_error=done.orientation_error,
                         collision=collision)
    arm = whole_robot(args, traj, world, own)
    collision = bool(collision) or (arm is not None and arm.min_distance < 0)
    sim = run_simulation(args, traj, world, own) if args.simulate else None
    status = 0 if sim is None or sim.confirmed else 1
    if args.out is not None:
        write_trajectory(traj, args.out, format=kind, **writing)
    plot = None
    if args.plot is not None:
        from ..plotting import plot_edit  # matplotlib, as above

        plot = plot_edit(Y, args.plot, demo=demos[0], demos=demos[1:], constraints=constraints,
                         title=f"{args.method}: {Path(args.input[0]).name}")
    if args.json:
        doc = {**executable_dict(traj, orientation_error=done.orientation_error, peaks=done.peaks,
                                 notes=notes + done.notes),
               "used": [str(p) for p in args.input], "rejected": {}, "constraint_error": float(error),
               "collision": bool(collision)}
        if metrics is not None:
            doc["metrics"] = metrics
        if plot is not None:
            doc["plot"] = str(plot)
        if arm is not None:
            doc["clearance"] = arm.summary()
        if sim is not None:
            doc["simulation"] = sim.to_dict()
        print(json.dumps(doc, allow_nan=False))
        return status
    print(f"{args.method}: {len(demos)} demonstration(s) -> {Y.shape[0]} samples, {Y.shape[1]} dimensions")
    print_execution(traj, error, done.orientation_error, collision, done.peaks, done.notes,
                    orientation=constraints.has_orientation)
    if arm is not None:
        print_clearance(arm)
    if metrics is not None:
        print("  " + ", ".join(f"{k} {v:.4g}" for k, v in metrics.items()))
    for note in notes:
        print(f"  warning: {' '.join(note.split())}")
    if sim is not None:
        print_simulation(sim)
    for path in (args.out, plot):
        if path is not None:
            print(f"  wrote {path}")
    return status
