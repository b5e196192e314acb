"""Benchmark of the numerical inverse kinematics on the Panda (7 joints): vectorised, per-pose loop, mink.

Run from the repository root::

    .venv/bin/python benchmarks/bench_ik_chain.py [--sizes 100 1000 10000] [--seeds 0 1 2]
        [--repeats 3] [--peer-max 10000] [--json PATH]

Case: a smooth tool-pose path of N samples on the registered ``panda`` (robosuite 1.5.2's MJCF, the grip
site as the tool): the forward kinematics of a joint path that swings every joint about the home
posture by 0.2-0.5 rad (amplitudes and phases drawn from the seed, inside the joint limits). Every
solver starts from the path's first joints and solves the poses in order. Timed, best of
``--repeats`` (``time.perf_counter``), in the same run:

- **skillbank, vectorised**: ``robot_model("panda").ik(P, Q, q_seed=q0)``, the path solved coarse to
  fine in batches (damped least squares, the null space pulled to the seed and away from the limits),
  its checks (reach, limits, singularity, jumps) included;
- **skillbank, per-pose loop**: ``ik_loop``, the same solver one pose at a time, each seeded by the one
  before (the straightforward implementation);
- **mink** 0.0.5 (Apache-2.0; the version robosuite 1.5.2 pins, so the ``sim`` extra already has it):
  differential IK as a quadratic program (``FrameTask`` on the same grip site, the joint limits as
  constraints, solver ``quadprog``, Levenberg-Marquardt damping 1e-12), iterated per pose from the
  previous pose's joints until the error is within the same tolerance or 50 iterations. Without a
  posture task its redundancy is resolved by the smallest step from the previous pose, which keeps
  the path continuous; a ``PostureTask`` is a soft cost that holds the pose a few micrometres off
  the target (measured: 9 % of poses within 1e-6 m at cost 1e-3), so it is left out.

Reported per solver: time, the share of poses reached within skillbank's tolerance (1e-6 m, and
1e-6 m / the arm's length in rad), the largest position and orientation error, and the largest
joint step between consecutive samples (the path stays on one branch when it is small), and how far
the joints end from the ones the path was drawn from (the 7th joint's freedom: the null space pulls
skillbank's solution to the seed, mink's follows the smallest steps). Every
figure is given over ``--seeds`` paths (best time of each seed: the median and range; errors:
the worst). No timing is asserted.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
from pathlib import Path

import numpy as np

from skillbank.core import quaternion_angle, quaternion_to_matrix
from skillbank.robots import robot_model

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_of  # noqa: E402

MINK_ITERATIONS = 50


def path(n: int, seed: int):
    """A smooth pose path of n samples and its joints ``(n, 7)``: every joint swings about home.

    Paths that pass within twice the singularity threshold of a singularity (the folded elbow near
    joint 4's limit) are drawn again: the benchmark times paths the arm can follow.
    """
    robot = robot_model("panda")
    rng = np.random.default_rng(seed)
    home = np.asarray(robot.home)
    lo, hi = np.asarray(robot.lower), np.asarray(robot.upper)
    room = np.minimum(home - lo, hi - home) - 0.05  # stay clear of the limits
    s = np.linspace(0.0, 1.0, n)[:, None]
    while True:
        amplitude = np.minimum(rng.uniform(0.2, 0.5, 7), room)
        phase = rng.uniform(0, 2 * np.pi, 7)
        q = home + amplitude * np.sin(2 * np.pi * s * rng.uniform(0.5, 1.5, 7) + phase)
        if robot._singularity(q)["jacobian"].min() > 2 * robot.singularity_thresholds["jacobian"]:
            break
    position, quaternion = robot.fk(q)
    return position, quaternion, q


def errors(robot, q, position, quaternion, drawn):
    p, r = robot.fk(q)
    ep = np.linalg.norm(p - position, axis=1)
    er = quaternion_angle(r, quaternion)
    ok = (ep <= robot.tolerance * (1 + 1e-9)) & (er <= robot.tolerance / robot.length_ * (1 + 1e-9))
    step = float(np.abs(np.diff(q, axis=0)).max()) if len(q) > 1 else 0.0
    return {"success": float(ok.mean()), "max_position_error": float(ep.max()),
            "max_orientation_error": float(er.max()), "max_joint_step": step,
            "max_from_drawn": float(np.abs(q - drawn).max())}


class MinkPanda:
    """mink on the same MJCF and tool: one differential-IK loop per pose, warm-started."""

    def __init__(self, robot):
        import mink
        import mujoco

        # the file, tool frame and tool offset the model itself was read with
        spec = mujoco.MjSpec.from_file(robot.chain.source)
        spec.body(robot.chain.tool_frame).add_site(name="bench_tool", pos=robot.tool[:3, 3].tolist())
        self.mink, self.model = mink, spec.compile()
        self.robot = robot
        self.frame = mink.FrameTask("bench_tool", "site", position_cost=1.0, orientation_cost=1.0)
        self.limits = [mink.ConfigurationLimit(self.model)]

    def solve(self, position, quaternion, q0) -> np.ndarray:
        mink = self.mink
        conf = mink.Configuration(self.model, q=np.asarray(q0, float))
        R = quaternion_to_matrix(quaternion)
        tol_p, tol_r = self.robot.tolerance, self.robot.tolerance / self.robot.length_
        out = np.empty((len(position), self.model.nq))
        for k in range(len(position)):
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = R[k], position[k]
            self.frame.set_target(mink.SE3.from_matrix(T))
            for _ in range(MINK_ITERATIONS):
                err = self.frame.compute_error(conf)
                if np.linalg.norm(err[:3]) <= tol_p and np.linalg.norm(err[3:]) <= tol_r:
                    break
                v = mink.solve_ik(conf, [self.frame], 1.0, "quadprog", damping=1e-12, limits=self.limits)
                conf.integrate_inplace(v, 1.0)
            out[k] = conf.q
        return out


def run(sizes, seeds, repeats: int, peer_max: int) -> list[dict]:
    robot = robot_model("panda")
    try:
        peer = MinkPanda(robot)
    except ImportError:
        peer = None
        print("mink not installed (it comes with the extra skillbank[sim]); the peer's column is empty")
    rows = []
    for n in sizes:
        row = {"n": n}
        paths = [path(n, seed) for seed in seeds]  # drawn once: every solver gets the same poses
        for name, solve in (
            ("vectorised", lambda P, Q, q0: robot.ik(P, Q, q_seed=q0)),
            ("loop", lambda P, Q, q0: robot.ik_loop(P, Q, q_seed=q0)),
            ("mink", None if peer is None or n > peer_max else peer.solve),
        ):
            if solve is None:
                continue
            times, worst = [], {"success": 1.0, "max_position_error": 0.0, "max_orientation_error": 0.0,
                                "max_joint_step": 0.0, "max_from_drawn": 0.0}
            for P, Q, q in paths:
                t, sol = best_of(lambda f=solve, P=P, Q=Q, q0=q[0]: f(P, Q, q0), repeats)
                times.append(t)
                e = errors(robot, sol, P, Q, q)
                worst = {"success": min(worst["success"], e["success"]),
                         **{k: max(worst[k], e[k]) for k in list(worst)[1:]}}
            row[name] = {"seconds_median": float(np.median(times)), "seconds_min": float(min(times)),
                         "seconds_max": float(max(times)), **worst}
        rows.append(row)
    return rows


def markdown(rows) -> str:
    lines = ["| poses | solver | time (s), median [range] over seeds | poses reached "
             "| max position error (m) | max orientation error (rad) "
             "| max joint step (rad) | max from the drawn joints (rad) "
             "| time / vectorised |",
             "|---:|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        base = r["vectorised"]["seconds_median"]
        for name in ("vectorised", "loop", "mink"):
            if name not in r:
                continue
            s = r[name]
            lines.append(
                f"| {r['n']} | {name} | {s['seconds_median']:.3g} "
                f"[{s['seconds_min']:.3g}, {s['seconds_max']:.3g}] | {100 * s['success']:.1f} % "
                f"| {s['max_position_error']:.1e} | {s['max_orientation_error']:.1e} "
                f"| {s['max_joint_step']:.3f} | {s['max_from_drawn']:.3f} "
                f"| {s['seconds_median'] / base:.1f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[100, 1_000, 10_000])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--peer-max", type=int, default=10_000, help="largest N mink runs at")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    rows = run(args.sizes, args.seeds, args.repeats, args.peer_max)
    print(f"python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}, "
          f"seeds {args.seeds}, best of {args.repeats}")
    print(markdown(rows))
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
