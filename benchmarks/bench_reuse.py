"""Leave-one-out reuse benchmark on RAIL: skillbank's selection against two baselines.

Run from the repository root::

    .venv/bin/python benchmarks/bench_reuse.py [--classes reaching pressing] [--limit 10] [--all]
        [--n-steps 200] [--ranks shortlist length deformation endpoints] [--library] [--json PATH]
        [--data DIR]

For each held-out demonstration of a class, the library holds the other
demonstrations of that class. The task is the held-out demonstration's start
and goal. Every demonstration is first resampled (linearly in phase) to
``--n-steps`` samples on one time base, so that all trajectories are compared
at equal length. Errors to the held-out demonstration: DTW (divided by the
number of samples, so a mean distance per sample, in metres) and discrete
Fréchet (metres).

Compared, in the same run:

- **skillbank** ``selection.reuse`` with each method (lte, ja, promp, elmap,
  dmp) and each ranking: ``shortlist`` (the default: the 3 candidates the edit
  deformed least, shortest adapted curve first), ``length`` (the paper's
  curve length over all candidates: shortest adapted curve first),
  ``deformation`` (least root-mean-square edit first) and ``endpoints`` (the
  candidate's own start and end nearest to the requested ones first). The candidates are adapted once per task
  (``select_candidates``) and shared by the methods; a method's time is the
  adaptation time plus its own fit and reproduction.
- **nearest**: the stored demonstration whose start and end are nearest the
  requested ones (sum of the two distances), returned without adaptation.
- **dmp-random**: a DMP learned from one stored demonstration drawn at random
  (seeded), reproduced with the requested start and goal.

``--library`` also runs the reuse through a real :class:`skillbank.pipeline.Library`
(one SQLite file per class, demonstrations stored whole under the class label;
the held-out one removed and re-added around its turn) with its default
ranking and ProMP, as a check that the stored round trip gives the same result.

Held-out demonstrations: ``--limit`` per class, evenly spread over the class
(default 10), or all with ``--all``. No timing is asserted anywhere.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

from skillbank import Constraints
from skillbank.core import resample
from skillbank.io import load_rail
from skillbank.metrics import dtw_distance, frechet_distance
from skillbank.representations import DMP
from skillbank.selection import METHODS, RANKINGS, reproduce_selection, select_candidates

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import data_dir  # noqa: E402

CLASSES = ("reaching", "pushing", "pressing", "writing")




def errors(P, Q, n):
    return dtw_distance(P, Q) / n, frechet_distance(P, Q)


def nearest(library, start, goal):
    starts = np.stack([Y[0] for Y in library])
    goals = np.stack([Y[-1] for Y in library])
    return int(np.argmin(np.linalg.norm(starts - start, axis=1) + np.linalg.norm(goals - goal, axis=1)))


def run_class(name, arrays, held_out, t, *, ranks, methods, rng, library_check=None):
    """Rows ``{"class", "method", "held_out", "dtw", "frechet", "time"}`` for one class."""
    n = t.shape[0]
    rows = []
    for h in held_out:
        target = arrays[h]
        others = [i for i in range(len(arrays)) if i != h]
        library = [arrays[i] for i in others]
        task = Constraints(start=target[0], goal=target[-1])

        def record(method, P, seconds, used=None, target=target, h=h):
            dtw, fr = errors(P, target, n)
            rows.append({"class": name, "method": method, "held_out": int(h), "dtw": dtw, "frechet": fr,
                         "time": seconds, "used": used})

        for rank in ranks:
            t0 = time.perf_counter()
            sel = select_candidates(library, task, ids=others, t=t, rank=rank)
            t_sel = time.perf_counter() - t0
            for method in methods:
                t0 = time.perf_counter()
                res = reproduce_selection(sel, task, method=method, random_state=0, t=t)
                record(f"skillbank {method} ({rank})", res.trajectory["position"],
                       t_sel + time.perf_counter() - t0, res.used)
        t0 = time.perf_counter()
        j = nearest(library, task.start, task.goal)
        record("baseline: nearest, unadapted", library[j], time.perf_counter() - t0, [others[j]])
        t0 = time.perf_counter()
        j = int(rng.integers(len(library)))
        P = DMP().fit(library[j]).reproduce(task, n_steps=n)["position"]
        record("baseline: dmp from a random demo", P, time.perf_counter() - t0, [others[j]])
        if library_check is not None:
            t0 = time.perf_counter()
            P = library_check(h, task)
            record("skillbank Library.reuse promp (shortlist, the default)", P, time.perf_counter() - t0)
    return rows


def library_checker(folder, name, demos, t):
    """A function ``(held_out, task) -> trajectory`` that reuses through a real Library."""
    from skillbank import Demonstration
    from skillbank.pipeline import Library

    lib = Library(Path(folder) / f"{name}.sqlite")
    stored = [Demonstration.from_array(resample(d["position"], t.shape[0]), t, metadata={"source": str(i)})
              for i, d in enumerate(demos)]
    ids = lib.add_many(stored, segment=False, label=name, assign="none")

    def check(h, task):
        lib.remove(ids[h])
        try:
            return lib.reuse(name, task, method="promp", random_state=0).trajectory["position"]
        finally:
            ids[h] = lib.add(stored[h], segment=False, label=name, assign="none")

    return check, lib


def summarise(rows):
    """``{class: {method: {"dtw", "frechet", "time", "n"}}}`` with means."""
    table: dict = {}
    for r in rows:
        table.setdefault(r["class"], {}).setdefault(r["method"], []).append(r)
    out = {}
    for cls, by_method in table.items():
        out[cls] = {}
        for method, rs in by_method.items():
            out[cls][method] = {k: float(np.mean([r[k] for r in rs])) for k in ("dtw", "frechet", "time")}
            out[cls][method]["n"] = len(rs)
    return out


def markdown(summary) -> str:
    lines = []
    for cls, by_method in summary.items():
        base = min(v["dtw"] for m, v in by_method.items() if m.startswith("baseline"))
        base_fr = min(v["frechet"] for m, v in by_method.items() if m.startswith("baseline"))
        n = next(iter(by_method.values()))["n"]
        lines += [f"### {cls} ({n} held out)", "",
                  "| method | DTW / n (mm) | Fréchet (mm) | time (ms) | beats both baselines |",
                  "| --- | ---: | ---: | ---: | :---: |"]
        for method, v in sorted(by_method.items(), key=lambda kv: kv[1]["dtw"]):
            beats = "" if method.startswith("baseline") else (
                "yes" if v["dtw"] < base and v["frechet"] < base_fr else
                "DTW only" if v["dtw"] < base else "Fréchet only" if v["frechet"] < base_fr else "no")
            lines.append(f"| {method} | {1e3 * v['dtw']:.1f} | {1e3 * v['frechet']:.1f} | "
                         f"{1e3 * v['time']:.1f} | {beats} |")
        lines.append("")
    return "\n".join(lines)


def overall(rows) -> dict:
    """Mean over all held-out demonstrations of all classes, per method."""
    return summarise([dict(r, **{"class": "all classes"}) for r in rows])


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=None, help="shared data folder (holds rail/)")
    parser.add_argument("--classes", nargs="+", default=list(CLASSES), choices=CLASSES)
    parser.add_argument("--limit", type=int, default=10, help="held-out demos per class (default 10)")
    parser.add_argument("--all", action="store_true", help="hold out every demonstration")
    parser.add_argument("--n-steps", type=int, default=200, help="samples per trajectory (default 200)")
    parser.add_argument("--ranks", nargs="+", default=["shortlist", "length", "deformation", "endpoints"],
                        choices=list(RANKINGS))
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=list(METHODS))
    parser.add_argument("--seed", type=int, default=0, help="seed of the random-demo DMP baseline")
    parser.add_argument("--library", action="store_true", help="also reuse through a real Library")
    parser.add_argument("--json", metavar="PATH", help="also write all rows and means as JSON")
    args = parser.parse_args(argv)
    if args.n_steps < 3:
        parser.error(f"--n-steps: expected at least 3, got {args.n_steps}")
    data = args.data or data_dir()
    if not (data / "rail").is_dir():
        parser.error(f"--data: no rail/ folder in {data}; set SKILLBANK_DATA or pass --data")
    rng = np.random.default_rng(args.seed)
    t = np.linspace(0.0, 1.0, args.n_steps)
    rows, tmp = [], None
    t_start = time.perf_counter()
    for name in args.classes:
        demos = load_rail(data / "rail", classes=[name])
        arrays = [resample(d["position"], args.n_steps) for d in demos]
        held = range(len(arrays)) if args.all else np.unique(
            np.linspace(0, len(arrays) - 1, min(args.limit, len(arrays))).round().astype(int))
        check, lib = None, None
        if args.library:
            import tempfile

            tmp = tmp or tempfile.TemporaryDirectory()
            check, lib = library_checker(tmp.name, name, demos, t)
        rows += run_class(name, arrays, list(held), t, ranks=args.ranks, methods=args.methods, rng=rng,
                          library_check=check)
        if lib is not None:
            lib.close()
        print(f"{name}: {len(held)} held out, {time.perf_counter() - t_start:.1f} s so far", file=sys.stderr)
    summary = summarise(rows)
    print(f"# Reuse benchmark (RAIL, leave-one-out, {args.n_steps} samples, seed {args.seed})\n")
    print(f"Python {platform.python_version()}, numpy {np.__version__}; total "
          f"{time.perf_counter() - t_start:.1f} s\n")
    print(markdown(overall(rows)))
    print(markdown(summary))
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "summary": summary}, indent=1, default=str))


if __name__ == "__main__":
    main()
