"""Benchmark of the UR5e's vectorised inverse kinematics against a per-pose loop of the same formulas.

Run from the repository root::

    .venv/bin/python benchmarks/bench_ik.py [--sizes 100 1000 10000] [--loop-max 10000] [--repeats 5]
        [--json PATH]

Case: N poses, the forward kinematics of N random configurations (seeded,
joints uniform in [-pi, pi)). Timed, best of ``--repeats``
(``time.perf_counter``), in the same run:

- **all branches, vectorised**: ``UR5e().ik_all(position, quaternion)``, the
  8 branches of every pose in numpy, validation included;
- **all branches, per-pose loop**: :func:`ik_loop`, the same formulas one
  pose and one branch at a time with Python's ``math`` (the straightforward
  implementation; ``tests/robots/test_ur5e.py`` checks the two agree to
  1e-12);
- **path, vectorised**: ``UR5e().ik(position, quaternion, q_seed=...)``
  along a smooth pose path of N samples (one branch chosen, unwrapped,
  checked for singularities, flips and limits).

The ratio is loop / vectorised at the same N. The issue's target is IK for
10^4 poses well under 0.1 s. No timing is asserted.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
from pathlib import Path

import numpy as np

from skillbank.robots import UR5E_DH, UR5e

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_of  # noqa: E402

_D1, _, _, _D4, _D5, _D6 = UR5E_DH["d"]
_A2, _A3 = UR5E_DH["a"][1:3]


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def ik_one(T) -> list[list[float]]:
    """The 8 branches ``[[theta1..6], ...]`` of one flange pose (4 x 4), NaN rows where a branch cannot reach.

    Branch order as ``UR5e.branch_names``: shoulder left / right, then elbow up / down, then wrist up /
    down; up means the shoulder's sign in the formula, down the other.
    """
    x, y, z, p = ([T[i][k] for i in range(3)] for k in range(4))
    p5 = [p[i] - _D6 * z[i] for i in range(3)]
    r = math.hypot(p5[0], p5[1])
    out = []
    for s in (-1.0, 1.0):
        for e in (1.0, -1.0):
            for w in (1.0, -1.0):
                if r < _D4 * (1 - 1e-12):
                    out.append([math.nan] * 6)
                    continue
                t1 = math.atan2(p5[1], p5[0]) + s * math.acos(min(_D4 / r, 1.0)) + math.pi / 2
                s1, c1 = math.sin(t1), math.cos(t1)
                t5 = s * w * math.acos(max(-1.0, min(1.0, z[0] * s1 - z[1] * c1)))
                sn5 = math.sin(t5)
                sign5 = (sn5 > 0) - (sn5 < 0)
                t6 = math.atan2(-sign5 * (y[0] * s1 - y[1] * c1), sign5 * (x[0] * s1 - x[1] * c1))
                u = [math.sin(t6) * x[i] + math.cos(t6) * y[i] for i in range(3)]
                t234 = math.atan2(-(u[0] * c1 + u[1] * s1), u[2])
                px = p5[0] * c1 + p5[1] * s1 - _D5 * math.sin(t234)
                py = p5[2] - _D1 + _D5 * math.cos(t234)
                c3 = (px * px + py * py - _A2 * _A2 - _A3 * _A3) / (2 * _A2 * _A3)
                if abs(c3) > 1 + 1e-12:
                    out.append([math.nan] * 6)
                    continue
                t3 = s * e * math.acos(max(-1.0, min(1.0, c3)))
                t2 = math.atan2(py, px) - math.atan2(_A3 * math.sin(t3), _A2 + _A3 * math.cos(t3))
                t4 = t234 - t2 - t3
                out.append([_wrap(a) for a in (t1, t2, t3, t4, t5, t6)])
    return out


def ik_loop(T) -> np.ndarray:
    """:func:`ik_one` for each pose of ``T (n, 4, 4)``: ``(n, 8, 6)``."""
    return np.array([ik_one(pose.tolist()) for pose in T])


def poses(n: int, seed: int = 0):
    robot = UR5e()
    q = np.random.default_rng(seed).uniform(-np.pi, np.pi, (n, 6))
    return robot.fk(q)


def path(n: int):
    """A smooth pose path of n samples around the ready pose (every joint swings by up to 0.6 rad)."""
    s = np.linspace(0.0, 1.0, n)[:, None]
    q = np.asarray(UR5e.home) + 0.6 * np.sin(np.pi * s * np.arange(1, 7)[None, :] / 3)
    return UR5e().fk(q), q[0]


def run(sizes, loop_max: int, repeats: int) -> list[dict]:
    robot = UR5e()
    rows = []
    for n in sizes:
        position, quaternion = poses(n)
        t_vec, sols = best_of(lambda p=position, q=quaternion: robot.ik_all(p, q), repeats)
        row = {"n": n, "ik_all": t_vec}
        if n <= loop_max:
            T, _ = robot._poses(position, quaternion)
            t_loop, ref = best_of(lambda T=T: ik_loop(T), max(1, repeats // 2))
            same = np.isnan(ref) == np.isnan(sols)
            diff = np.nanmax(np.abs(wrap(ref - sols))) if same.all() else float("nan")
            row.update(loop=t_loop, ratio=t_loop / t_vec, max_diff=float(diff))
        (pp, qq), seed = path(n)
        row["ik_path"], _ = best_of(lambda p=pp, q=qq, s=seed: robot.ik(p, q, q_seed=s), repeats)
        rows.append(row)
    return rows


def wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def markdown(rows) -> str:
    lines = ["| poses | ik_all vectorised (s) | per-pose loop (s) | loop / vectorised | max diff (rad) "
             "| ik along a path (s) |", "|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        loop = f"{r['loop']:.4g}" if "loop" in r else "-"
        ratio = f"{r['ratio']:.0f}" if "ratio" in r else "-"
        diff = f"{r['max_diff']:.1e}" if "max_diff" in r else "-"
        lines.append(f"| {r['n']} | {r['ik_all']:.4g} | {loop} | {ratio} | {diff} | {r['ik_path']:.4g} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100, 1_000, 10_000])
    parser.add_argument("--loop-max", type=int, default=10_000, help="largest N the per-pose loop runs at")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    rows = run(args.sizes, args.loop_max, args.repeats)
    print(f"python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}")
    print(markdown(rows))
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
