"""Tasks composed from single demonstrations, planned and carried out in robosuite (issue 26).

For each experiment, the path a user runs: ``skillbank experiment NAME --episodes N --seed S --json``
(record the demonstrations, build the library, label one primitive per skill, describe pick and place,
plan and execute each episode in a fresh scene), with skillbank's adaptation (``lte``), and with the
baseline that replays each phase's recorded actions in the planned order (``replay``), on the same
recordings and the same scenes. Success rates with their Wilson 95 % intervals and the failure
reasons.

    python benchmarks/bench_composition.py --episodes 20 --seed 30
    python benchmarks/bench_composition.py --episodes 20 --seed 60 --methods lte   # another library, scenes
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

EXPERIMENTS = ["unload", "stack3"]
METHODS = ["lte", "replay"]


def run(name: str, method: str, episodes: int, seed: int, demos: int, replan: bool) -> dict:
    args = [sys.executable, "-m", "skillbank.cli", "experiment", name, "--episodes", str(episodes), "--seed",
            str(seed), "--demos", str(demos), "--method", method, "--json"] + (["--replan"] if replan else [])
    tic = time.perf_counter()
    done = subprocess.run(args, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(args[2:])}: {done.stderr.strip().splitlines()[-1]}")
    report = json.loads(done.stdout)
    report["wall_seconds"] = time.perf_counter() - tic
    return report


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--seed", type=int, default=30)
    parser.add_argument("--demos", type=int, default=10)
    parser.add_argument("--experiments", nargs="+", default=EXPERIMENTS)
    parser.add_argument("--methods", nargs="+", default=METHODS)
    parser.add_argument("--replan", action="store_true", help="also run lte with --replan")
    parser.add_argument("--out", default=None, help="write every report as JSON to this file")
    args = parser.parse_args()
    rows, reports = [], []
    for name in args.experiments:
        runs = [(m, False) for m in args.methods] + ([("lte", True)] if args.replan else [])
        for method, replan in runs:
            r = run(name, method, args.episodes, args.seed, args.demos, replan)
            reports.append(r)
            lo, hi = r["interval"]
            fails = ", ".join(f"{k} {v}" for k, v in sorted(r["failures"].items())) or "-"
            label = method + (" + replan" if replan else "")
            rate = f"{r['successes']}/{r['episodes']} = {100 * r['success_rate']:.0f} %"
            rows.append(f"| {name} | {label} | {rate} [{100 * lo:.1f}, {100 * hi:.1f}] | {fails} | "
                        f"{r['wall_seconds']:.0f} s |")
            print(rows[-1], flush=True)
    print(f"\nskillbank experiment NAME --episodes {args.episodes} --seed {args.seed} --demos {args.demos}")
    print("| experiment | method | successes (Wilson 95 %) | failures | wall time |")
    print("|---|---|---|---|---|")
    print("\n".join(rows))
    if args.out:
        with open(args.out, "w") as fh:
            json.dump(reports, fh)


if __name__ == "__main__":
    main()
