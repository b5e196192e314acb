"""``skillbank library export``, ``import`` and ``copy``: a library moved as files or between stores."""

from __future__ import annotations

import contextlib
import json

from ._library_location import _URL, _open, _target
from ._options import show_progress

__all__ = ["_export", "_import", "_copy"]


def _export(args) -> int:
    with _open(args, readonly=True) as lib:
        manifest = lib.export(args.folder, progress=show_progress(args))
        n = len(lib.demonstration_ids())
    if args.json:
        print(json.dumps({"folder": str(args.folder), "manifest": str(manifest), "demonstrations": n}))
        return 0
    print(f"{args.db}: exported {n} demonstration(s) to {args.folder} ({manifest.name})")
    return 0


@contextlib.contextmanager
def _new_file_removed_on_failure(location):
    """A library file this command creates is removed again (with WAL's side files) when the command fails."""
    new = None if isinstance(location, _URL) or location.exists() else location
    try:
        yield
    except BaseException:
        for path in () if new is None else (new, new.with_name(new.name + "-wal"),
                                             new.with_name(new.name + "-shm")):
            path.unlink(missing_ok=True)
        raise


def _import(args) -> int:
    with _new_file_removed_on_failure(args.db), _open(args, create=True) as lib:
        res = lib.import_folder(args.folder, max_bytes=args.max_bytes)
    kinds = ("demonstrations", "primitives", "versions")
    added = {k: len(res[k]) for k in kinds}
    if args.json:
        ids = {k: {str(a): b for a, b in res[k].items()} for k in kinds}
        print(json.dumps({"mode": res["mode"], "added": added, "skipped": len(res["skipped"]),
                          "assigned": len(res["assigned"]), **ids,
                          "duplicates": {str(a): b for a, b in res["skipped"].items()}}))
        return 0
    line = (f"{args.db}: imported {added['demonstrations']} demonstration(s), {added['primitives']} "
            f"primitive(s), {added['versions']} clustering version(s)")
    if res["mode"] == "copy":
        print(f"{line} (an exact copy)")
        return 0
    print(f"{line} (merged); skipped {len(res['skipped'])} demonstration(s) already in the library; "
          f"assigned {len(res['assigned'])} primitive(s) to the current clusters")
    return 0


def _copy(args) -> int:
    # the progress bar and the store alone: a copy needs no pipeline (scikit-learn)
    from tqdm import tqdm

    from ..store import copy_library, open_store  # as above

    def tick(done, total):
        bar.total = total
        bar.update(done - bar.n)

    with _new_file_removed_on_failure(args.dst), \
            open_store(_target(args.src), create=False, readonly=True) as src, \
            open_store(_target(args.dst)) as dst, \
            tqdm(desc="copying", unit="demo", disable=not show_progress(args)) as bar:
        counts = copy_library(src, dst, progress=tick)
    if args.json:
        print(json.dumps({"source": str(args.src), "destination": str(args.dst), **counts}))
        return 0
    print(f"{args.dst}: copied {counts['demonstrations']} demonstration(s), {counts['primitives']} "
          f"primitive(s) and {counts['versions']} clustering version(s) from {args.src}")
    return 0
