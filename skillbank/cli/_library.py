"""``skillbank library``: build, cluster, label, query and reuse a motion-primitive library."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from ..core._relation_words import describe_relation
from ..core._text import printable
from ..core._validation import summarise
from ._cluster import FEATURE_KIND, LIBRARY_FEATURES, library_features
from ._library_location import _DB, _DB_READ, _URL, _library, _location, _open
from ._library_transfer import _copy, _export, _import
from ._library_view import add_view_parser, check_view, write_library_view
from ._options import (
    add_constraint_options,
    add_execution_options,
    add_parallel_options,
    add_reader_options,
    add_segmentation_options,
    constraints_from_args,
    execution_params,
    export_params,
    parallel_params,
    reader_options,
    segmentation_params,
    show_progress,
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

__all__ = ["add_parser"]

def add_parser(sub):
    """Register ``library`` and its sub-commands on argparse subparsers ``sub``.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="skillbank")
    >>> add_parser(parser.add_subparsers(dest="command"))  # doctest: +ELLIPSIS
    ArgumentParser(...)
    """
    p = sub.add_parser("library", help="a durable library of motion primitives (SQLite or PostgreSQL)")
    cmds = p.add_subparsers(dest="library_command", required=True)

    c = cmds.add_parser("init", help="create an empty library (a file, or tables in a PostgreSQL database)")
    c.add_argument("db", type=_location, help="the library file or postgresql:// URL (its database must "
                                              "exist) to create; an existing library is checked and left "
                                              "as it is, with status 0 (init may be run again)")
    c.add_argument("--json", action="store_true", help="print the library, whether it was created, and its "
                                                       "schema version as JSON")
    c.set_defaults(func=_init)

    c = cmds.add_parser("add", help="segment demonstrations and store their primitives (all files or none, "
                                    "unless --keep-going)")
    c.add_argument("db", type=_location, help=_DB)
    c.add_argument("files", nargs="+", type=Path,
                   help="demonstration files (.h5, .mat, .csv, .npz, ROS 1/2 bags, .mcap, LeRobot dataset "
                        "folders, robomimic .hdf5)")
    add_segmentation_options(c)
    add_reader_options(c)
    c.add_argument("--whole", action="store_true", help="store each demonstration as one primitive")
    c.add_argument("--label", default=None, help="label every primitive added (default: a LeRobot episode's "
                   "task)")
    c.add_argument("--assign", choices=["incremental", "none", "recluster"], default="incremental",
                   help="put new primitives in the nearest existing cluster (default), leave them "
                        "unclustered, or recluster everything afterwards")
    c.add_argument("--keep-going", action="store_true",
                   help="add every file that reads and segments, list each bad one with its reason, and "
                        "exit with status 2 if any failed (default: a bad file adds nothing)")
    c.add_argument("--json", action="store_true",
                   help="print the new ids, the failed files and the unclustered demonstrations as JSON")
    add_parallel_options(c)
    c.set_defaults(func=_add)

    c = cmds.add_parser("cluster", help="(re)cluster every primitive; records a new version")
    c.add_argument("db", type=_location, help=_DB)
    c.add_argument("--stretch", type=float, default=None, help="stretching constant (default 1.2)")
    c.add_argument("--features", type=library_features, choices=LIBRARY_FEATURES, default="heading",
                   help="heading (default): direction over time in each primitive's heading frame, as "
                        "'cluster --features heading'; position: the positions resampled. Two of 'cluster''s "
                        "featurisers only, and its default is heading, not 'cluster''s default: the library "
                        "stores its featuriser with the clustering and applies it to the primitives added "
                        "later, which these two allow ('default' is still read as heading)")
    c.add_argument("--seed", type=int, default=0, help="random seed (first elastic node, PCA; default 0)")
    c.add_argument("--plot", type=Path, default=None,
                   help="write a figure of the clusters (features and each cluster's primitives) to this "
                        "file (.png, .pdf, .svg; no extension: .png)")
    c.add_argument("--json", action="store_true", help="print the new version as JSON")
    c.set_defaults(func=_cluster)

    c = cmds.add_parser("label", help="label a cluster (current version) or a primitive")
    c.add_argument("db", type=_location, help=_DB)
    which = c.add_mutually_exclusive_group(required=True)
    which.add_argument("--cluster", type=int, default=None, help="cluster id (see 'library list')")
    which.add_argument("--primitive", type=int, default=None, help="primitive id")
    c.add_argument("name", help="the label, e.g. 'press' (then 'library reuse --skill press')")
    c.add_argument("--json", action="store_true", help="print what was labelled as JSON")
    c.set_defaults(func=_label)

    c = cmds.add_parser("list", help="skills with counts and labels, unassigned primitives, then primitives")
    c.add_argument("db", type=_location, help=_DB_READ)
    c.add_argument("--json", action="store_true", help="print the library summary as JSON")
    c.set_defaults(func=_list)

    c = cmds.add_parser("describe", help="attach a PDDL action schema and its binding to a skill label "
                                         "(for 'skillbank plan'); without --action, show it")
    c.add_argument("db", type=_location, help=_DB)
    c.add_argument("label", help="the skill's label; the action must be named like it")
    c.add_argument("--action", type=Path, default=None, metavar="FILE.pddl",
                   help="a file holding one (:action LABEL :parameters (...) :precondition ... :effect ...)")
    c.add_argument("--binding", default=None, metavar="JSON",
                   help="how the action binds to geometry, a JSON object or a .json file: goal (a "
                        "parameter), offset [dx,dy,dz], orientation, obstacles, gripper {start,end}, "
                        "method, duration, velocity (see docs/planning.md)")
    c.add_argument("--remove", action="store_true", help="remove the label's description (a new revision)")
    c.add_argument("--json", action="store_true", help="print the description as JSON")
    c.set_defaults(func=_describe)

    c = cmds.add_parser("reuse", help="reproduce a skill under new constraints")
    c.add_argument("db", type=_location, help=_DB_READ)
    c.add_argument("--skill", required=True, help="a label, or a cluster id")
    add_constraint_options(c)
    c.add_argument("--method", default="promp",
                   help="a representation of skillbank.representations.REPRESENTATIONS: promp (default), "
                        "lte, ja, elmap, dmp. Its default is not 'edit''s and 'sim evaluate''s lte, which "
                        "adapt one demonstration: reuse hands the method the best --k candidates of the "
                        "skill, and promp learns from all of them")
    c.add_argument("--k", type=int, default=None, help="candidates passed to the representation")
    c.add_argument("--rank", default="shortlist",
                   help="candidate ranking (default shortlist: the least deformed candidates, "
                        "shortest curve first; length: the paper's curve length over all)")
    c.add_argument("--shortlist", type=int, default=argparse.SUPPRESS,
                   help="shortlist size for --rank shortlist (default: skillbank.selection.SHORTLIST)")
    c.add_argument("--seed", type=int, default=None,
                   help="random seed for methods that sample (default: none, a fresh draw each run)")
    add_execution_options(c)
    c.add_argument("--out", type=Path, default=None,
                   help="write the result with every stream (.csv, .npz, .script, .bag; see --format)")
    add_force_option(c)
    c.add_argument("--plot", type=Path, default=None, help="write a figure of the reproduction")
    c.add_argument("--view", type=Path, default=None, metavar="DIR",
                   help="write the library's web view to DIR with the result's page (reuse.html: the "
                        "reproduction over the candidates, constraints, obstacles, joints, simulation)")
    c.add_argument("--json", action="store_true",
                   help="print the result as JSON: t, streams, joint_names, trajectory (the position path), "
                        "used, rejected, constraint_error, orientation_error, collision, peak_joint_velocity")
    c.set_defaults(func=_reuse)

    c = cmds.add_parser("export", help="write the library to a folder of NPZ files and a manifest")
    c.add_argument("db", type=_location, help=_DB_READ)
    c.add_argument("folder", type=Path, help="a new or empty folder to write to")
    c.add_argument("--json", action="store_true", help="print the folder, the manifest and the number of "
                                                       "demonstrations as JSON")
    c.set_defaults(func=_export)

    c = cmds.add_parser("import", help="copy an exported folder into an empty library, or merge it into "
                                       "a non-empty one (skipping demonstrations already there)")
    c.add_argument("db", type=_location, help="the library (created when missing)")
    c.add_argument("folder", type=Path, help="a folder written by 'library export'")
    c.add_argument("--max-bytes", type=float, default=None, metavar="BYTES",
                   help="the most bytes the export's arrays may take once decompressed, checked before any "
                        "is read (default 1 GiB, or $SKILLBANK_MAX_IMPORT_BYTES; e.g. 8e9)")
    c.add_argument("--json", action="store_true", help="print the counts and id maps as JSON")
    c.set_defaults(func=_import)

    c = cmds.add_parser("copy", help="copy a library into an empty one, between SQLite files and PostgreSQL "
                                     "(ids, versions and labels kept)")
    c.add_argument("src", type=_location, help="the library to copy, a file or a postgresql:// URL "
                                               "(opened read-only)")
    c.add_argument("dst", type=_location, help="an empty or new library (a file or a postgresql:// URL); a "
                                               "non-empty one is refused")
    c.add_argument("--json", action="store_true", help="print the counts copied as JSON")
    c.set_defaults(func=_copy)

    c = cmds.add_parser("remove", help="delete a demonstration with its primitives")
    c.add_argument("db", type=_location, help=_DB)
    c.add_argument("demonstration", type=int, help="id of the demonstration (see 'library list')")
    c.add_argument("--json", action="store_true",
                   help="print the removed demonstration and its primitives as JSON")
    c.set_defaults(func=_remove)

    add_view_parser(cmds)
    return p


def _init(args) -> int:
    url = isinstance(args.db, _URL)
    created = not url and not args.db.exists()
    # an existing library is validated (and migrated) and otherwise left as it is
    with _library(args.db, create=url or created) as lib:
        schema = lib.schema_version
        created = created or bool(getattr(lib.store, "created", False))  # a URL's store says
    if args.json:
        print(json.dumps({"library": str(args.db), "created": created, "schema_version": schema}))
    elif created:
        print(f"created library {args.db}")
    else:
        print(f"{args.db}: library already exists")
    return 0


def set_aside_line(set_aside: dict) -> str:
    """One line on the streams an add set aside as constant: each stream, why, and in which demonstrations.

    Examples
    --------
    >>> zero = {"torque": "constant: every value is 0"}
    >>> set_aside_line({3: zero, 4: zero}).split(", which")[0]
    "set aside stream 'torque' (constant: every value is 0) in demonstrations [3, 4]"
    """
    where: dict = {}
    for did, streams in set_aside.items():
        for stream, why in streams.items():
            where.setdefault((stream, why), []).append(did)
    parts = [f"stream {stream!r} ({why}) in demonstration{'s' if len(ids) > 1 else ''} [{summarise(ids)}]"
             for (stream, why), ids in where.items()]
    verb = "carry" if len(parts) > 1 else "carries"
    return f"set aside {'; '.join(parts)}, which {verb} no information; the others were segmented as usual"


def _add(args) -> int:
    segmentation = {"streams": args.stream, **segmentation_params(args)}
    with _open(args) as lib:
        report = lib.add_files(args.files, index=args.demo, group=args.group, segment=not args.whole,
                               repair_time=args.repair_time, reader_options=reader_options(args),
                               segmentation=segmentation, label=args.label, assign=args.assign,
                               keep_going=args.keep_going, progress=show_progress(args),
                               **parallel_params(args))
    command = getattr(args, "command_name", "skillbank library add")
    for path, reason in report["failed"].items():
        print(printable(f"{command}: skipped {path}: {reason}"), file=sys.stderr)  # a file name may hold ESC
    if report.get("set_aside"):
        print(printable(f"{command}: {set_aside_line(report['set_aside'])}"), file=sys.stderr)
    if args.json:
        print(json.dumps(report))
    else:
        n = sum(len(p) for p in report["primitives"])
        print(f"{args.db}: added {len(report['demonstrations'])} demonstration(s) with {n} primitive(s)")
        n_prims = dict(zip(report["demonstrations"], map(len, report["primitives"]), strict=True))
        for did, why in report["unclustered"].items():
            print(f"  demonstration {did}: {n_prims[did]} primitive(s) left unclustered: {why}")
        if report["version"] is not None:
            print(f"  reclustered: clustering version {report['version']}")
    if report["failed"]:
        n, bad = len(args.files), len(report["failed"])
        print(f"{command}: error: {bad} of {n} file(s) failed and were skipped; the other {n - bad} were "
              "added", file=sys.stderr)
        return 2
    return 0


def _cluster(args) -> int:
    plot = None
    if args.plot is not None:
        from ..plotting import figure_path  # matplotlib only when a figure is asked for

        figure_path(args.plot, name="plot")  # a bad name fails before the work, not after
    with _open(args) as lib:
        version = lib.cluster(stretch=args.stretch, features=FEATURE_KIND[args.features],
                              random_state=args.seed,
                              progress=show_progress(args))
        skills = lib.summary()["skills"]
        if args.plot is not None:
            from ..plotting import plot_cluster_comparison  # matplotlib, as above

            prims = [p for p in lib.primitives(load=True) if p.cluster is not None]
            plot = plot_cluster_comparison(
                np.array([p.features for p in prims]), {f"version {version}": [p.cluster for p in prims]},
                args.plot, trajectories=[p.demo["position"] for p in prims],
                title=f"{args.db.name}: clustering version {version}, {len(skills)} skill(s)")
    if args.json:
        doc = {"version": version, "skills": skills}
        print(json.dumps(doc if plot is None else {**doc, "plot": str(plot)}))
        return 0
    print(f"{args.db}: clustering version {version}: {len(skills)} skill(s)")
    for s in skills:
        print(f"  cluster {s['cluster']}: {s['count']} primitive(s), label {s['label'] or '-'}")
    if plot is not None:
        print(f"  wrote {plot}")
    return 0


def _label(args) -> int:
    with _open(args) as lib:
        lib.label(args.name, cluster=args.cluster, primitive=args.primitive)
        version = lib.store.current_version()
    if args.json:
        print(json.dumps({"label": args.name.strip(), "cluster": args.cluster, "primitive": args.primitive,
                          "version": version}))
        return 0
    what = f"cluster {args.cluster}" if args.cluster is not None else f"primitive {args.primitive}"
    print(f"{args.db}: labelled {what} {args.name!r}")
    return 0


def _list(args) -> int:
    with _open(args, readonly=True) as lib:
        doc = lib.summary()
    if args.json:
        print(json.dumps(doc))
        return 0
    print(f"{args.db}: {doc['n_demonstrations']} demonstration(s), {len(doc['primitives'])} primitive(s)")
    points = {}
    for d in doc["demonstrations"]:
        points.setdefault(d["pose_of"], []).append(d["id"])
    for point, ids in points.items():
        shown = ", ".join(map(str, ids[:20])) + (", ..." if len(ids) > 20 else "")
        said = (f"the {point}" if point is not None else
                "an unknown point (library add --pose-of says which; a robot needs it)")
        print(f"poses of {said}: demonstration(s) {shown}")
    print("skills:" if doc["skills"] else "skills: none (run 'skillbank library cluster')")
    for s in doc["skills"]:
        how = f" ({s['label_source']})" if s["label"] and s.get("label_source") else ""
        print(f"  cluster {s['cluster']}: {s['count']} primitive(s), label {s['label'] or '-'}{how}")
    unassigned = doc["unassigned"]
    if doc["version"] is not None and unassigned["count"]:
        shown = ", ".join(map(str, unassigned["ids"][:20])) + (", ..." if unassigned["count"] > 20 else "")
        print(f"unassigned: {unassigned['count']} primitive(s) in no cluster of version {doc['version']}: "
              f"{shown} (run 'skillbank library cluster')")
    print("primitives:")
    for p in doc["primitives"]:
        cluster = "-" if p["cluster"] is None else p["cluster"]
        acts = p.get("acts_on")
        on = "" if acts is None else f", {describe_relation(acts)}"
        arm = "" if p.get("arm_index") is None else f" (arm {p['arm_index']})"
        print(f"  {p['id']}: demonstration {p['demonstration']}{arm}, cluster {cluster}, "
              f"label {p['label'] or '-'}{_how(p)}, {p['n_steps']} samples{on}")
    return 0


def _how(p) -> str:
    """Who said a primitive's label: `` (given)`` to it, `` (cluster)`` to its cluster, `` (inferred)``."""
    return f" ({p['label_source']})" if p["label"] and p.get("label_source") else ""


def _skill(lib, name: str):
    """A label when some primitive carries it, else a cluster id when ``name`` is an integer."""
    if lib.primitives(label=name, load=False):
        return name
    try:
        return int(name)
    except ValueError:
        return name


def output_format(args):
    """The format of ``--out`` (checked before any work), or None without ``--out``."""
    from ..io import trajectory_format  # the writers, only when a result is written

    if args.out is None:
        if args.format is not None:
            raise ValueError(f"format: --format {args.format} needs --out FILE")
        return None
    kind = trajectory_format(args.out, args.format)
    if kind == "rosbag" and args.out.exists():
        raise ValueError(f"out: {str(args.out)!r} already exists; a ROS 2 bag is written to a new folder")
    if not args.out.parent.is_dir():
        raise ValueError(f"out: folder {str(args.out.parent)!r} does not exist")
    return kind


def check_robot(args) -> None:
    """An unknown robot name or a bad description file fails before the work (the registry's names listed)."""
    from ._execution_options import cli_robot  # the one place --robot becomes a model

    cli_robot(args)


def _binding(text):
    """``--binding``: a JSON object, or a file holding one (size and nesting bounded as a scene's)."""
    if text is None:
        return None
    # The planning package imports scipy: only when a binding is given (showing a description needs none).
    from ..planning._json import load_json, parse_json
    from ..planning._scene import MAX_SCENE_BYTES  # the same size bound as a scene's

    if not text.lstrip().startswith("{"):
        path = Path(text)
        if not path.is_file():
            raise ValueError(f"binding: expected a JSON object or a .json file, got {text!r}")
        return load_json(path, "binding", MAX_SCENE_BYTES)
    return parse_json(text, "binding")


def _describe(args) -> int:
    if args.remove and (args.action is not None or args.binding is not None):
        raise ValueError("remove: --remove takes neither --action nor --binding")
    if args.action is None and args.binding is not None:
        raise ValueError("binding: --binding needs --action FILE.pddl too")
    action = None
    if args.action is not None:
        if not args.action.is_file():
            raise ValueError(f"action: expected a PDDL file, got {str(args.action)!r}, which is not a file")
        action = args.action.read_text(encoding="utf-8")
    binding = _binding(args.binding)
    with _open(args, readonly=action is None and not args.remove) as lib:
        if action is not None or args.remove:
            lib.describe(args.label, action, binding)
        found = [d for d in lib.descriptions() if d["label"] == args.label]
    doc = found[0] if found else {"label": args.label, "action": None}
    if args.json:
        print(json.dumps(doc))
        return 0
    if not found:
        print(f"{args.db}: skill {args.label!r} has no description")
        return 0
    print(f"{args.db}: skill {args.label!r}, description revision {doc['revision']} ({doc['created']})")
    print("  " + doc["action"].replace("\n", "\n  "))
    print(f"  binding {json.dumps(doc['binding'])}")
    return 0


def _reuse(args) -> int:
    from .. import io  # the writers, only when a result is written

    constraints = constraints_from_args(args.start, args.goal, args.via, args.obstacle,
                                        start_orientation=args.start_orientation,
                                        goal_orientation=args.goal_orientation,
                                        via_orientation=args.via_orientation)
    options = {"shortlist": args.shortlist} if hasattr(args, "shortlist") else {}
    execution = execution_params(args)
    check_robot(args)
    margin = clearance_margin(args)
    world = load_world(args)
    own = tuple(constraints.obstacles)
    constraints = world_constraints(constraints, world)
    kind = output_format(args)
    writing = export_params(args, kind, execution["duration"])
    if args.plot is not None:
        from ..plotting import figure_path  # matplotlib only when a figure is asked for

        figure_path(args.plot, name="plot")  # a bad name fails before the work, not after
    if args.view is not None:
        check_view(args.view)
    with _open(args, readonly=True) as lib:
        skill = _skill(lib, args.skill)
        result = lib.reuse(skill, constraints, method=args.method, k=args.k, rank=args.rank,
                           random_state=args.seed, progress=show_progress(args), clearance_margin=margin,
                           **options, **execution)
        used = {p.id: p.demo for p in lib.skill(skill)} if args.plot is not None or args.view else {}
    arm = whole_robot(args, result.trajectory, world, own)
    collision = bool(result.collision) or (arm is not None and arm.min_distance < 0)
    sim = run_simulation(args, result.trajectory, world, own) if args.simulate else None
    status = 0 if sim is None or sim.confirmed else 1
    if args.out is not None:
        io.write_trajectory(result.trajectory, args.out, format=kind, **writing)
    if args.plot is not None:
        from ..plotting import plot_edit  # matplotlib only when a figure is asked for

        plot_edit(result.trajectory, args.plot, demos=[used[i] for i in result.used if i in used],
                  constraints=constraints, title=f"skill {args.skill}")
    view = None
    if args.view is not None:
        from ..plotting._view_result import reuse_page  # the web view, only when one is asked for

        page = reuse_page(result, skill=args.skill, method=args.method, constraints=constraints,
                          stored=[(pid, demo["position"]) for pid, demo in used.items()], simulation=sim)
        view = write_library_view(args, {"reuse.html": page})
    if args.json:
        doc = result.to_dict()
        doc["collision"] = collision
        if arm is not None:
            doc["clearance"] = arm.summary()
        if sim is not None:
            doc["simulation"] = sim.to_dict()
        if view is not None:
            doc["view"] = view
        print(json.dumps(doc, allow_nan=False))
        return status
    print(f"{args.db}: skill {args.skill!r} reproduced with {args.method} from primitive(s) {result.used}")
    print_execution(result.trajectory, result.constraint_error, result.orientation_error, collision,
                    result.peaks, result.notes, orientation=constraints.has_orientation)
    if arm is not None:
        print_clearance(arm)
    for pid, reason in result.rejected.items():
        print(f"  rejected {pid}: {reason}")
    if sim is not None:
        print_simulation(sim)
    for path in (args.out, args.plot):
        if path is not None:
            print(f"  wrote {path}")
    if view is not None:
        print(f"  wrote the view with the result: open {view['pages']['reuse.html']}")
    return status


def print_execution(traj, constraint_error, orientation_error, collision, peaks, notes,
                    orientation: bool = False) -> None:
    """The text report of an executable result (shared by ``library reuse`` and ``edit``).

    A plain position edit keeps its two lines; orientation, other streams and timing add theirs.
    """
    rotation = f", orientation error {orientation_error:.3g} rad" if orientation else ""
    print(f"  constraint error {constraint_error:.3g}{rotation}, collision {'yes' if collision else 'no'}")
    if traj.stream_names != ["position"] or traj.metadata.get("time_scale", 1.0) != 1.0:
        print(f"  {traj.n_steps} samples over {traj.t[-1] - traj.t[0]:.4g} s from t = 0; streams "
              f"{', '.join(traj.stream_names)}")
    if "joints" in peaks:
        print(f"  peak joint velocity {peaks['joints']['velocity']:.4g} rad/s, acceleration "
              f"{peaks['joints']['acceleration']:.4g} rad/s^2")
    for note in notes:
        print(f"  note: {' '.join(note.split())}")


def _remove(args) -> int:
    with _open(args) as lib:
        prims = [p.id for p in lib.primitives(demonstration=args.demonstration, load=False)]
        lib.remove(args.demonstration)
    if args.json:
        print(json.dumps({"removed": args.demonstration, "primitives": prims}))
        return 0
    print(f"{args.db}: removed demonstration {args.demonstration} with {len(prims)} primitive(s)")
    return 0

