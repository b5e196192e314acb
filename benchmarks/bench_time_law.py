"""Benchmark of the time law (issue 43, item 4): TOPP-RA against the uniform stretch, and ruckig measured.

Run from the repository root::

    .venv/bin/python benchmarks/bench_time_law.py [--data DIR] [--samples 262 2620] [--paths 50]

1. The paper's three-button press reproduction (``--data``, default
   ``SKILLBANK_DATA`` or ``../shared/data``; the skill and task of
   ``bench_reuse_robot.py``: the first press's goal moved by (5, -3, 0) cm and
   turned 10 deg), ``Library.reuse(..., method="ja", robot="ur5e")`` under
   the UR5e's own limits (180 deg/s, 180 deg/s^2), with
   ``time_law="uniform"`` (the stretch skillbank used before) and
   ``"toppra"`` (the default now): the trajectory's duration, the largest
   measured limit ratio (``rate_ratio``: <= 1 is within), and the reuse's
   compute time (best of 3). The same joint path is then timed by ruckig
   (MIT; ``pip install ruckig``, optional) the two ways its community
   version can without its cloud API: through every sample, stopping at each
   (the path kept), and straight from the first to the last configuration
   (the path not kept: its largest distance from the samples is given).
2. ``--paths`` random smooth joint paths (the generator of
   ``tests/robots/test_time_law.py``): the law's duration over the uniform
   stretch's (median, largest) and the compute time of each law.

No timing is asserted.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_of  # noqa: E402
from bench_reuse_robot import _library  # noqa: E402

from skillbank.pipeline import Library  # noqa: E402
from skillbank.robots import UR5e, rate_ratio, time_law  # noqa: E402


def _ruckig(q: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray):
    """ruckig's durations through every sample (stopping at each) and straight to the end, and the
    straight move's largest distance from the samples (rad), or None without ruckig."""
    try:
        from ruckig import InputParameter, Result, Ruckig, Synchronization, Trajectory
    except ImportError:
        return None
    dofs = q.shape[1]
    otg = Ruckig(dofs)

    def move(a, b):
        inp = InputParameter(dofs)
        inp.current_position, inp.target_position = list(a), list(b)
        inp.max_velocity, inp.max_acceleration = list(velocity), list(acceleration)
        inp.max_jerk = [np.inf] * dofs  # second order, as TOPP-RA and the uniform stretch
        inp.synchronization = Synchronization.Phase  # a straight line in joint space
        traj = Trajectory(dofs)
        if otg.calculate(inp, traj) not in (Result.Working, Result.Finished):
            raise RuntimeError("ruckig failed")
        return traj

    start = time.perf_counter()
    stops = sum(move(a, b).duration for a, b in zip(q[:-1], q[1:], strict=True) if np.any(a != b))
    stop_s = time.perf_counter() - start
    straight = move(q[0], q[-1])
    chord = q[-1] - q[0]
    u = np.clip((q - q[0]) @ chord / (chord @ chord), 0.0, 1.0)
    off = float(np.linalg.norm(q - q[0] - np.outer(u, chord), axis=1).max())
    return stops, stop_s, straight.duration, off


def _random_path(seed: int):
    rng = np.random.default_rng(seed)
    n_joints, n = int(rng.integers(1, 8)), int(rng.integers(50, 300))
    s = np.linspace(0.0, 1.0, n)[:, None]
    amp, freq = rng.uniform(-1.5, 1.5, (3, n_joints)), rng.uniform(0.2, 2.0, (3, n_joints))
    q = rng.uniform(-2.0, 2.0, n_joints) + sum(amp[k] * np.sin(np.pi * freq[k] * s + k) for k in range(3))
    t = rng.uniform(0.05, 10.0) * s[:, 0]
    return q, t, rng.uniform(0.3, 4.0, n_joints), rng.uniform(0.5, 10.0, n_joints)


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path(os.environ.get("SKILLBANK_DATA", "../shared/data")))
    parser.add_argument("--samples", type=int, nargs="+", default=[262, 2620])
    parser.add_argument("--paths", type=int, default=50)
    args = parser.parse_args(argv)
    data = args.data if args.data.is_dir() else None
    print(f"Python {platform.python_version()}, numpy {np.__version__}, "
          f"{'three-button presses' if data else 'synthetic_ur5e moves'}\n")
    robot = UR5e()
    vmax, amax = robot.rate_limits["joint_velocity"], robot.rate_limits["joint_acceleration"]
    time_law(np.linspace(0.0, 1.0, 5)[:, None], velocity=1.0)  # toppra's import (1.6 s) out of the timings
    out = {"press": [], "random": {}}
    print("| samples | law | duration (s) | limit ratio | reuse (s) |")
    print("|--:|---|--:|--:|--:|")
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.samples:
            task, _ = _library(Path(tmp) / f"base_{n}.sqlite", data, n)
            with Library(Path(tmp) / f"press_{n}.sqlite") as lib:
                for law in ("uniform", "toppra"):
                    seconds, res = best_of(lambda lib=lib, law=law, task=task: lib.reuse(
                        "press", task, method="ja", robot="ur5e", time_law=law), 3)
                    traj = res.trajectory
                    ratio = rate_ratio(traj.t, traj["joints"], velocity=vmax, acceleration=amax)
                    out["press"].append({"samples": n, "law": law, "duration": float(traj.t[-1]),
                                         "ratio": ratio, "seconds": seconds})
                    print(f"| {n} | {law} | {traj.t[-1]:.3f} | {ratio:.6f} | {seconds:.3f} |", flush=True)
            ruck = _ruckig(traj["joints"], vmax, amax)
            if ruck is not None:
                stops, stop_s, straight, off = ruck
                print(f"| {n} | ruckig, stopping at every sample (path kept) | {stops:.3f} | - | "
                      f"{stop_s:.3f} (ruckig only) |")
                print(f"| {n} | ruckig, straight to the end (path not kept: {off:.3f} rad off) | "
                      f"{straight:.3f} | - | - |")
                out["press"].append({"samples": n, "ruckig_stops": stops, "ruckig_straight": straight,
                                     "straight_off": off})
    ratios, toppra_s, uniform_s = [], [], []
    for seed in range(args.paths):
        q, t, v, a = _random_path(seed)
        s_u, uniform = best_of(lambda q=q, t=t, v=v, a=a: time_law(q, velocity=v, acceleration=a, t=t,
                                                                  law="uniform"), 3)
        s_t, law = best_of(lambda q=q, t=t, v=v, a=a: time_law(q, velocity=v, acceleration=a, t=t,
                                                              ends="given"), 3)
        ratios.append(law[-1] / uniform[-1])
        toppra_s.append(s_t)
        uniform_s.append(s_u)
    ratios = np.array(ratios)
    out["random"] = {"median": float(np.median(ratios)), "max": float(ratios.max()),
                     "toppra_ms": 1e3 * float(np.median(toppra_s)),
                     "uniform_ms": 1e3 * float(np.median(uniform_s))}
    print(f"\n{args.paths} random joint paths: toppra / uniform duration median {np.median(ratios):.3f}, "
          f"largest {ratios.max():.3f}, smallest {ratios.min():.3f}; compute median "
          f"{out['random']['toppra_ms']:.1f} ms (toppra) vs {out['random']['uniform_ms']:.2f} ms (uniform)")
    return out


if __name__ == "__main__":
    main()
