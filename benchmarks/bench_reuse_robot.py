"""Benchmark of reuse with ``robot="ur5e"``: the whole executable reproduction against a per-pose IK loop.

Run from the repository root::

    .venv/bin/python benchmarks/bench_reuse_robot.py [--data DIR] [--samples 262 2620 26200]

The skill is the three-button demonstration's presses (``--data``, default
``SKILLBANK_DATA`` or ``../shared/data``), labelled 'press' after the default
segmentation; without the data, the moves of ``synthetic_ur5e``. The task
moves the first press's goal by (5, -3, 0) cm and turns it 10 deg about the
tool axis. Each primitive is resampled to ``--samples`` samples first, so the
IK runs on paths of that length.

- ``skillbank``: ``Library.reuse(..., method="ja", robot="ur5e")``: reuse,
  orientation edit, gripper, timing, and IK for the whole path (vectorised,
  every branch, one followed).
- ``baseline``: the same reuse without ``robot``, then a straightforward
  per-pose loop of the same closed-form IK (``bench_ik.ik_one``), keeping the
  branch solution nearest the previous sample's joints (the first seeded with
  the primitive's recorded joints), unwrapped onto them.
- ``CLI``: ``skillbank library reuse ... --robot ur5e --out x.csv`` in a child
  process (start-up included), against the same command without ``--robot``.

Both give the same joints (largest difference reported). Best of 3. No
timing is asserted.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_of, run_child  # noqa: E402
from bench_ik import ik_one  # noqa: E402

from skillbank import Constraints, Demonstration  # noqa: E402
from skillbank.core import exp_map, quaternion_to_matrix, slerp  # noqa: E402
from skillbank.pipeline import Library  # noqa: E402


def _library(path: Path, data: Path | None, n_samples: int) -> tuple[Constraints, np.ndarray]:
    """A library whose 'press' skill holds the presses, each resampled to ``n_samples``; the task."""
    if data is not None and (data / "seed" / "three_button_pressing_demo.h5").is_file():
        from skillbank.io import read_robot_h5

        demo = read_robot_h5(data / "seed" / "three_button_pressing_demo.h5")
        pick = slice(1, 4)  # the default cuts: gripper, three presses, gripper
    else:
        from skillbank.experiments import synthetic_ur5e

        demo, pick = synthetic_ur5e(), slice(0, 3)
    with Library(path, create=True) as lib:
        lib.add(demo, assign="none")
        prims = sorted(lib.primitives(), key=lambda p: p.start)[pick]
        parts = []
        for p in prims:
            d = p.demo
            t = np.linspace(d.t[0], d.t[-1], n_samples)
            parts.append(Demonstration(t, {k: slerp(d.t, d[k], t) if k == "orientation" else
                                           np.column_stack([np.interp(t, d.t, c) for c in d[k].T])
                                           for k in d.stream_names}, d.metadata))
    with Library(path.with_name(f"press_{n_samples}.sqlite"), create=True) as lib:
        lib.add_many(parts, segment=False, label="press", assign="none")
    first = parts[0]
    task = Constraints(start=first["position"][0], goal=first["position"][-1] + [0.05, -0.03, 0.0],
                       start_orientation=first["orientation"][0],
                       goal_orientation=exp_map([0.0, 0.0, np.radians(10.0)],
                                                reference=first["orientation"][-1]))
    return task, first["joints"][0]


def baseline_joints(trajectory, seed) -> np.ndarray:
    """Per-pose IK loop: every branch of each pose, the one nearest the previous joints, unwrapped."""
    R = quaternion_to_matrix(trajectory["orientation"])
    P = trajectory["position"]
    previous = np.asarray(seed, dtype=float)
    out = []
    for i in range(P.shape[0]):
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R[i], P[i]
        best, best_d = None, np.inf
        for q in ik_one(T.tolist()):
            q = np.asarray(q)
            if np.isnan(q).any():
                continue
            q = previous + (q - previous + np.pi) % (2 * np.pi) - np.pi  # nearest equivalent angles
            d = float(np.abs(q - previous).max())
            if d < best_d:
                best, best_d = q, d
        if best is None:
            raise ValueError(f"sample {i}: unreachable")
        out.append(best)
        previous = best
    return np.array(out)


def main(argv=None) -> list:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=Path(os.environ.get("SKILLBANK_DATA", "../shared/data")))
    parser.add_argument("--samples", type=int, nargs="+", default=[262, 2620, 26200])
    args = parser.parse_args(argv)
    data = args.data if args.data.is_dir() else None
    print(f"Python {platform.python_version()}, numpy {np.__version__}, "
          f"{'three-button presses' if data else 'synthetic_ur5e moves'}\n")
    print("| samples | reuse + IK, skillbank (s) | reuse, then per-pose IK loop (s) | loop / skillbank "
          "| max joint difference (rad) | CLI --robot ur5e (s) | CLI without --robot (s) |")
    print("|--:|--:|--:|--:|--:|--:|--:|")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.samples:
            task, seed = _library(Path(tmp) / f"base_{n}.sqlite", data, n)
            db = Path(tmp) / f"press_{n}.sqlite"
            with Library(db) as lib:
                fast_s, fast = best_of(lambda lib=lib, task=task: lib.reuse("press", task, method="ja",
                                                                            robot="ur5e"), 3)

                def loop(lib=lib, task=task, seed=seed):
                    res = lib.reuse("press", task, method="ja")
                    return res, baseline_joints(res.trajectory, seed)

                slow_s, (plain, joints) = best_of(loop, 3)
            diff = float(np.abs(fast.trajectory["joints"] - joints).max())
            goal = ",".join(f"{v:.6f}" for v in task.goal)
            orient = ",".join(f"{v:.6f}" for v in task.goal_orientation)
            cmd = [str(Path(sys.executable).parent / "skillbank"), "library", "reuse", str(db),
                   "--skill", "press", "--method", "ja", "--goal", goal, "--goal-orientation", orient,
                   "--out", str(Path(tmp) / "x.csv")]
            cli = min(run_child(cmd + ["--robot", "ur5e"]).seconds for _ in range(3))
            plain_cli = min(run_child(cmd).seconds for _ in range(3))
            rows.append({"samples": n, "skillbank_s": fast_s, "baseline_s": slow_s, "max_diff": diff,
                         "cli_robot_s": cli, "cli_s": plain_cli})
            print(f"| {n} | {fast_s:.3f} | {slow_s:.3f} | {slow_s / fast_s:.1f} | {diff:.1e} | {cli:.2f} "
                  f"| {plain_cli:.2f} |", flush=True)
    return rows


if __name__ == "__main__":
    main()
