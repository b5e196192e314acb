"""Episodes in parallel (issue 42, item 6): episodes per second in this process, on 1 and on 2 Dask workers.

The path a user runs, through the command line, on the same seeds each time:

1. ``skillbank sim record robosuite:TASK --episodes DEMOS --seed 11`` and ``library add --assign
   recluster`` (a small library; ``--db`` gives one instead);
2. ``skillbank sim evaluate LIB --env robosuite:TASK --episodes N --seed 500 --placement 0.12 --json``
   without ``--workers`` (in this process), then with ``--workers 1`` and ``--workers 2`` (a new local
   Dask cluster of one or two worker processes).

Each run's wall-clock time counts everything a user waits for: Python starting, the library read, the
cluster started and stopped, the workers importing robosuite. Episodes per second are N divided by it.
The three configurations are run in turn ``--repeats`` times (interleaved, so that the load other work
puts on the machine falls on all of them alike) and the best time of each is kept; the CPU seconds of
each run (user and system, the command and every process it started) and the load average are printed
beside it. The runs must give the same report, episode for episode (every per-episode field of
``--json``, in seed order), or the script fails.

    python benchmarks/bench_parallel_episodes.py --episodes 12 --repeats 2
    python benchmarks/bench_parallel_episodes.py --task Stack --episodes 8 --json results.json
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import robosuite_library, skillbank  # noqa: E402


def evaluate(db: Path, task: str, episodes: int, workers) -> tuple[float, float, dict]:
    """``(wall seconds, CPU seconds of the command and its processes, report)`` of one run."""
    args = ["sim", "evaluate", db, "--env", f"robosuite:{task}", "--episodes", episodes, "--seed", 500,
            "--placement", 0.12, "--json"]
    if workers is not None:
        args += ["--workers", workers]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    tic = time.perf_counter()
    doc = json.loads(skillbank(*args))
    wall = time.perf_counter() - tic
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, doc


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="Lift", help="robosuite task (default Lift)")
    parser.add_argument("--episodes", type=int, default=12, help="episodes per run (default 12)")
    parser.add_argument("--demos", type=int, default=3, help="demonstrations recorded (default 3)")
    parser.add_argument("--db", type=Path, default=None, help="a library to evaluate instead of recording")
    parser.add_argument("--repeats", type=int, default=2, help="runs of each configuration (default 2)")
    parser.add_argument("--json", type=Path, default=None, help="also write the results here")
    args = parser.parse_args(argv)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    with tempfile.TemporaryDirectory() as tmp:
        db = args.db if args.db is not None else robosuite_library(Path(tmp), args.task, 11, args.demos)
        runs, rows = {}, []
        for _ in range(args.repeats):
            for label, workers in (("this process", None), ("--workers 1", 1), ("--workers 2", 2)):
                load = os.getloadavg()[0]
                seconds, cpu, doc = evaluate(db, args.task, args.episodes, workers)
                rows.append(doc["per_episode"])
                print(f"{label:>13}: {seconds:6.1f} s, {args.episodes / seconds:.3f} episodes/s, "
                      f"CPU {cpu:.1f} s, {doc['successes']}/{args.episodes} succeeded (load average "
                      f"{load:.1f})", flush=True)
                best = runs.get(label)
                if best is None or seconds < best["seconds"]:
                    runs[label] = {"seconds": seconds, "episodes_per_second": args.episodes / seconds,
                                   "cpu_seconds": cpu, "load_average": load, "successes": doc["successes"]}
    identical = all(r == rows[0] for r in rows[1:])
    one, two = runs["--workers 1"]["seconds"], runs["--workers 2"]["seconds"]
    print(f"best of {args.repeats}: " + ", ".join(f"{k} {v['episodes_per_second']:.3f} episodes/s"
                                                 for k, v in runs.items()))
    print(f"2 workers against 1: {one / two:.2f}x; against this process: "
          f"{runs['this process']['seconds'] / two:.2f}x; {cores} core(s); per-episode rows identical: "
          f"{identical}")
    if args.json is not None:
        args.json.write_text(json.dumps({"task": args.task, "episodes": args.episodes, "cores": cores,
                                         "repeats": args.repeats,
                                         "runs": runs, "identical": identical}, indent=2))
    return 0 if identical else 1


if __name__ == "__main__":
    sys.exit(main())
