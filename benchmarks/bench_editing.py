"""Benchmark of skillbank's Laplacian trajectory editing against a dense least-squares baseline.

Run from the repository root::

    .venv/bin/python benchmarks/bench_editing.py [--dense-sizes 1000 2000 4000] [--json PATH]
        [--cli-sizes 1000 10000 100000] [--cli-metrics-sizes 1000 10000] [--cli-repeats 3] [--no-cli]

Case: a smooth 3-D path of N samples (N = 10^3, 10^4, 10^5), edited to a
moved start and goal and two moved via-points (phases 0.3 and 0.7). skillbank
uses hard constraints (``skillbank.editing.lte``); the baseline
(``benchmarks/_dense_lte.py``) is the authors' approach, dense
``numpy.linalg.lstsq`` with soft constraint rows of weight 1e9, run at the
sizes where it is feasible. Each time is the best of several repeats
(``time.perf_counter``); the ratio is baseline / skillbank at the same N. The
constraint error is the largest distance between a constrained sample and its
target; "max diff" is the largest difference between the two edited paths and
"energy" the baseline's Laplacian energy ``|L (P - Y)|^2`` over skillbank's
(1 when both find the LTE optimum; with weight 1e9 lstsq's default ``rcond``
cuts the Laplacian's small singular values and the baseline misses it).

``bench_ja(sizes)`` times the jerk-accuracy representation
(``skillbank.representations.JerkAccuracy``) at 10^3 and 10^4 samples when
it is available, and says it is skipped otherwise.

Then the command line beside the library (``benchmarks/bench_cli.py``, also runnable alone):
``skillbank edit FILE.csv --goal ... --obstacle sphere:... --json`` as a subprocess at the
``--cli-sizes`` against ``lte`` in this process, ``skillbank --help`` start-up, which heavy
packages each command imports, and ``--metrics`` time and peak memory at the
``--cli-metrics-sizes``. No timing is asserted.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
from pathlib import Path

import numpy as np
import scipy

from skillbank.core import Constraints
from skillbank.editing import lte

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_of  # noqa: E402
from _dense_lte import dense_laplacian, dense_lte  # noqa: E402

LTE_SIZES = (1_000, 10_000, 100_000)


def path(n: int) -> np.ndarray:
    s = np.linspace(0.0, 1.0, n)
    return np.column_stack([s, 0.2 * np.sin(3 * np.pi * s), 0.1 * np.cos(5 * s)])


def task(n: int) -> Constraints:
    Y = path(n)
    return Constraints(start=Y[0] + [0.02, -0.01, 0.0], goal=Y[-1] + [0.1, 0.05, -0.05],
                       via=[(0.3, [0.3, 0.3, 0.1]), (0.7, [0.7, -0.1, 0.05])])


def bench_lte(sizes, dense_sizes):
    rows = []
    for n in sorted(set(sizes) | set(dense_sizes)):
        Y, c = path(n), task(n)
        idx, pts = c.resolve(n)
        row = {"n": n}
        if n in sizes or n in dense_sizes:
            t_sb, res = best_of(lambda Y=Y, c=c: lte(Y, c), 5 if n <= 10_000 else 3)
            row.update(skillbank_s=t_sb, skillbank_error=res.constraint_error, success=res.success)
        if n in dense_sizes:
            t_d, P = best_of(lambda Y=Y, idx=idx, pts=pts: dense_lte(Y, idx, pts), 2 if n <= 2000 else 1)
            L = dense_laplacian(n)
            energy = float(np.sum((L @ (P - Y)) ** 2) / np.sum((L @ (res.Y - Y)) ** 2))
            row.update(dense_s=t_d, dense_error=c.position_error(P), ratio=t_d / t_sb,
                       max_diff=float(np.abs(P - res.Y).max()), energy_ratio=energy)
        rows.append(row)
    return rows


def bench_ja(sizes=(1_000, 10_000)):
    """Jerk-accuracy reproduction times, if ``skillbank.representations.JerkAccuracy`` exists."""
    try:
        from skillbank import Demonstration
        from skillbank.representations import JerkAccuracy
    except ImportError as exc:
        print(f"\nJA: skipped (skillbank.representations.JerkAccuracy not available: {exc})")
        return []
    rows = []
    for n in sizes:
        Y, c = path(n), task(n)
        demo = Demonstration(np.linspace(0.0, 1.0, n), {"position": Y})
        try:
            t_fit, model = best_of(lambda demo=demo: JerkAccuracy().fit([demo]), 1)
            t_rep, out = best_of(lambda model=model, c=c, n=n: model.reproduce(c, n_steps=n), 3)
            P = out["position"] if hasattr(out, "streams") else np.asarray(out)
            rows.append({"n": n, "fit_s": t_fit, "reproduce_s": t_rep, "error": c.position_error(P)})
        except Exception as exc:  # report, do not hide, whatever the other implementation raises
            rows.append({"n": n, "failed": f"{type(exc).__name__}: {exc}"})
    print("\n| N | JA fit (s) | JA reproduce (s) | constraint error |\n|---:|---:|---:|---:|")
    for r in rows:
        if "failed" in r:
            print(f"| {r['n']:,} | failed: {r['failed']} | | |")
        else:
            print(f"| {r['n']:,} | {r['fit_s']:.4f} | {r['reproduce_s']:.4f} | {r['error']:.2e} |")
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=list(LTE_SIZES))
    parser.add_argument("--dense-sizes", type=int, nargs="*", default=[1000, 2000])
    parser.add_argument("--json", type=Path)
    parser.add_argument("--cli-sizes", type=int, nargs="*", default=list(LTE_SIZES),
                        help="sizes of the command-line run (bench_cli.py)")
    parser.add_argument("--cli-metrics-sizes", type=int, nargs="*", default=[1000, 10000],
                        help="sizes of the command-line run with --metrics (quadratic time)")
    parser.add_argument("--cli-repeats", type=int, default=3, help="subprocess repeats (best of)")
    parser.add_argument("--no-cli", action="store_true", help="skip the command-line part")
    args = parser.parse_args(argv)
    print(f"python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}, "
          f"{platform.machine()}")
    rows = bench_lte(args.sizes, args.dense_sizes)
    print("\n| N | skillbank LTE (s) | dense lstsq (s) | ratio | skillbank error | dense error | max diff "
          "| energy |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        dense = (f"{r['dense_s']:.4f} | {r['ratio']:.0f}x | " if "dense_s" in r else "n/a | | ")
        tail = (f"{r['dense_error']:.1e} | {r['max_diff']:.1e} | {r['energy_ratio']:.3g}" if "dense_s" in r
                else "n/a | n/a | n/a")
        print(f"| {r['n']:,} | {r['skillbank_s']:.4f} | {dense}{r['skillbank_error']:.1e} | {tail} |")
    ja = bench_ja()
    cli = None
    if not args.no_cli:
        import bench_cli  # beside this file; sys.path is set above

        cli = bench_cli.run(args.cli_sizes, args.cli_metrics_sizes, args.cli_repeats)
    if args.json:
        args.json.write_text(json.dumps({"lte": rows, "ja": ja, "cli": cli}, indent=2, default=float))


if __name__ == "__main__":
    main()
