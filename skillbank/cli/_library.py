"""``skillbank library``: build, cluster, label, query and reuse a motion-primitive library."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from ._options import (
    add_constraint_options,
    add_segmentation_options,
    constraints_from_args,
    segmentation_params,
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
    p = sub.add_parser("library", help="a durable library of motion primitives (SQLite)")
    cmds = p.add_subparsers(dest="library_command", required=True)

    c = cmds.add_parser("init", help="create an empty library file")
    c.add_argument("db", type=Path)
    c.set_defaults(func=_init)

    c = cmds.add_parser("add", help="segment demonstrations and store their primitives")
    c.add_argument("db", type=Path)
    c.add_argument("files", nargs="+", type=Path, help="demonstration files (.h5, .mat, .csv, .npz)")
    add_segmentation_options(c)
    c.add_argument("--whole", action="store_true", help="store each demonstration as one primitive")
    c.add_argument("--label", default=None, help="label every primitive added")
    c.add_argument("--assign", choices=["incremental", "none", "recluster"], default="incremental",
                   help="put new primitives in the nearest existing cluster (default), leave them "
                        "unclustered, or recluster everything afterwards")
    c.add_argument("--json", action="store_true", help="print the new ids as JSON")
    c.set_defaults(func=_add)

    c = cmds.add_parser("cluster", help="(re)cluster every primitive; records a new version")
    c.add_argument("db", type=Path)
    c.add_argument("--stretch", type=float, default=None, help="stretching constant (default 1.2)")
    c.add_argument("--features", choices=["default", "position"], default="default",
                   help="direction over time in the heading frame (default) or resampled positions")
    c.add_argument("--seed", type=int, default=0, help="random seed")
    c.add_argument("--json", action="store_true", help="print the new version as JSON")
    c.set_defaults(func=_cluster)

    c = cmds.add_parser("label", help="label a cluster (current version) or a primitive")
    c.add_argument("db", type=Path)
    which = c.add_mutually_exclusive_group(required=True)
    which.add_argument("--cluster", type=int, default=None, help="cluster id (see 'library list')")
    which.add_argument("--primitive", type=int, default=None, help="primitive id")
    c.add_argument("name", help="the label")
    c.set_defaults(func=_label)

    c = cmds.add_parser("list", help="skills with counts and labels, then primitives")
    c.add_argument("db", type=Path)
    c.add_argument("--json", action="store_true", help="print the library summary as JSON")
    c.set_defaults(func=_list)

    c = cmds.add_parser("reuse", help="reproduce a skill under new constraints")
    c.add_argument("db", type=Path)
    c.add_argument("--skill", required=True, help="a label, or a cluster id")
    add_constraint_options(c)
    c.add_argument("--method", default="promp",
                   help="a representation of skillbank.representations.REPRESENTATIONS (default promp)")
    c.add_argument("--k", type=int, default=None, help="candidates passed to the representation")
    c.add_argument("--rank", default="shortlist",
                   help="candidate ranking (default shortlist: the least deformed candidates, "
                        "shortest curve first; length: the paper's curve length over all)")
    c.add_argument("--shortlist", type=int, default=argparse.SUPPRESS,
                   help="shortlist size for --rank shortlist (default: skillbank.selection.SHORTLIST)")
    c.add_argument("--seed", type=int, default=None, help="random seed")
    c.add_argument("--out", type=Path, default=None, help="write the trajectory (.npz or .csv)")
    c.add_argument("--plot", type=Path, default=None, help="write a figure of the reproduction")
    c.add_argument("--json", action="store_true", help="print the result as JSON")
    c.set_defaults(func=_reuse)

    c = cmds.add_parser("export", help="write the library to a folder of NPZ files and a manifest")
    c.add_argument("db", type=Path)
    c.add_argument("folder", type=Path)
    c.set_defaults(func=_export)

    c = cmds.add_parser("import", help="add the contents of an exported folder")
    c.add_argument("db", type=Path)
    c.add_argument("folder", type=Path)
    c.add_argument("--json", action="store_true", help="print the id maps as JSON")
    c.set_defaults(func=_import)

    c = cmds.add_parser("remove", help="delete a demonstration with its primitives")
    c.add_argument("db", type=Path)
    c.add_argument("demonstration", type=int)
    c.set_defaults(func=_remove)
    return p


def _library(location, **kwargs):
    # The pipeline pulls in scikit-learn; imported when a library command runs, not for --help.
    from ..pipeline import Library

    return Library(location, **kwargs)


def _open(args, *, create=False):
    return _library(args.db, create=create)


def _init(args) -> int:
    if args.db.exists():
        _library(args.db, create=False).close()  # validates; an existing library is left as it is
        print(f"{args.db}: library already exists")
        return 0
    _library(args.db).close()
    print(f"created library {args.db}")
    return 0


def _add(args) -> int:
    from .. import io  # h5py and scipy.io readers, only when files are read

    demos = []
    for path in args.files:
        loaded = [io.load(path, index=args.demo, group=args.group)] if args.demo is not None else \
            io.load_all(path, group=args.group)
        for demo in loaded:
            demo.metadata.setdefault("source", str(path))
        demos.extend(loaded)
    segmentation = {"streams": args.stream, **segmentation_params(args)}
    with _open(args) as lib:
        ids = lib.add_many(demos, segment=not args.whole, segmentation=segmentation, label=args.label,
                           assign=args.assign, progress=True)
        prims = [lib.primitives(demonstration=i, load=False) for i in ids]
    if args.json:
        print(json.dumps({"demonstrations": ids, "primitives": [[p.id for p in ps] for ps in prims]}))
        return 0
    n = sum(len(ps) for ps in prims)
    print(f"{args.db}: added {len(ids)} demonstration(s) with {n} primitive(s)")
    return 0


def _cluster(args) -> int:
    with _open(args) as lib:
        version = lib.cluster(stretch=args.stretch, features=args.features, random_state=args.seed)
        skills = lib.summary()["skills"]
    if args.json:
        print(json.dumps({"version": version, "skills": skills}))
        return 0
    print(f"{args.db}: clustering version {version}: {len(skills)} skill(s)")
    for s in skills:
        print(f"  cluster {s['cluster']}: {s['count']} primitive(s), label {s['label'] or '-'}")
    return 0


def _label(args) -> int:
    with _open(args) as lib:
        lib.label(args.name, cluster=args.cluster, primitive=args.primitive)
    what = f"cluster {args.cluster}" if args.cluster is not None else f"primitive {args.primitive}"
    print(f"{args.db}: labelled {what} {args.name!r}")
    return 0


def _list(args) -> int:
    with _open(args) as lib:
        doc = lib.summary()
    if args.json:
        print(json.dumps(doc))
        return 0
    print(f"{args.db}: {doc['n_demonstrations']} demonstration(s), {len(doc['primitives'])} primitive(s)")
    print("skills:" if doc["skills"] else "skills: none (run 'skillbank library cluster')")
    for s in doc["skills"]:
        print(f"  cluster {s['cluster']}: {s['count']} primitive(s), label {s['label'] or '-'}")
    print("primitives:")
    for p in doc["primitives"]:
        cluster = "-" if p["cluster"] is None else p["cluster"]
        print(f"  {p['id']}: demonstration {p['demonstration']}, cluster {cluster}, "
              f"label {p['label'] or '-'}, {p['n_steps']} samples")
    return 0


def _skill(lib, name: str):
    """A label when some primitive carries it, else a cluster id when ``name`` is an integer."""
    if lib.primitives(label=name, load=False):
        return name
    try:
        return int(name)
    except ValueError:
        return name


def _reuse(args) -> int:
    from .. import io  # the writers, only when a result is written

    constraints = constraints_from_args(args.start, args.goal, args.via, args.obstacle)
    options = {"shortlist": args.shortlist} if hasattr(args, "shortlist") else {}
    with _open(args) as lib:
        skill = _skill(lib, args.skill)
        result = lib.reuse(skill, constraints, method=args.method, k=args.k, rank=args.rank,
                           random_state=args.seed, **options)
        used = {p.id: p.demo for p in lib.skill(skill)} if args.plot is not None else {}
    if args.out is not None:
        writer = io.write_csv if args.out.suffix.lower() in (".csv", ".txt") else io.write_npz
        writer(result.trajectory, args.out)
    if args.plot is not None:
        from ..plotting import plot_edit  # matplotlib only when a figure is asked for

        plot_edit(result.trajectory, args.plot, demos=[used[i] for i in result.used if i in used],
                  constraints=constraints, title=f"skill {args.skill}")
    if args.json:
        print(json.dumps(result.to_dict()))
        return 0
    print(f"{args.db}: skill {args.skill!r} reproduced with {args.method} from primitive(s) {result.used}")
    collision = "yes" if result.collision else "no"
    print(f"  constraint error {result.constraint_error:.3g}, collision {collision}")
    for pid, reason in result.rejected.items():
        print(f"  rejected {pid}: {reason}")
    for path in (args.out, args.plot):
        if path is not None:
            print(f"  wrote {path}")
    return 0


def _export(args) -> int:
    with _open(args) as lib:
        manifest = lib.export(args.folder)
    print(f"{args.db}: exported to {args.folder} ({manifest.name})")
    return 0


def _import(args) -> int:
    with _open(args, create=True) as lib:
        maps = lib.import_folder(args.folder)
    if args.json:
        print(json.dumps({k: {str(a): b for a, b in v.items()} for k, v in maps.items()}))
        return 0
    print(f"{args.db}: imported {len(maps['demonstrations'])} demonstration(s), "
          f"{len(maps['primitives'])} primitive(s), {len(maps['versions'])} clustering version(s)")
    return 0


def _remove(args) -> int:
    with _open(args) as lib:
        lib.remove(args.demonstration)
    print(f"{args.db}: removed demonstration {args.demonstration}")
    return 0

