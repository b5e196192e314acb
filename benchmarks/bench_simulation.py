"""Benchmark of the whole-arm clearance check: vectorised, a per-sample loop, and MuJoCo's own distance.

Run from the repository root::

    .venv/bin/python benchmarks/bench_simulation.py [--samples 10000] [--loop-max 1000] [--repeats 3]
        [--quick] [--json PATH]

Case: the UR5e with its Robotiq 2F-85 (10 capsules, 24 self-collision pairs) along a smooth joint
trajectory of ``--samples`` samples (seeded sums of sines about the home pose), in a scene with a
table, a sphere, two boxes and workspace bounds: 10 x 4 + 9 (table) + 10 (workspace) + 24 = 83 pairs
per sample. Timed, best of ``--repeats`` (``time.perf_counter``), in the same run, on the same geometry:

- **vectorised**: ``clearance(robot, joints, ...)`` with ``max_move`` large (the caller's samples
  only, as the others), and once with the default densification (how many samples it checked);
- **per-sample loop**: :func:`loop_clearance`, one sample, one pair at a time through the same
  closed-form distances (the straightforward implementation), on the first ``--loop-max`` samples,
  its time scaled to all samples;
- **MuJoCo**: the capsules as geoms of mocap bodies moved to the link frames at each sample
  (``mj_kinematics``), and ``mj_geomDistance`` for every pair but the workspace's (MuJoCo has no
  inside-a-box distance), on the first ``--loop-max`` samples, scaled.

The disagreement is the largest difference of per-sample, per-pair distances where both are positive
(MuJoCo reports overlaps as its own penetration depth). No timing is asserted.

**Simulation speed**, the path a user runs: ``skillbank sim run TRAJ.npz --scene SCENE --json`` in a
child process, on the embedded synthetic UR5e recording (``skillbank.experiments.synthetic_ur5e``,
joints and gripper) in a scene with a table and a button under its lowest point; the real-time factor
the command reports (simulated seconds per second of physics) and the command's wall time (start-up
and reading included).
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
from pathlib import Path

import numpy as np

from skillbank.core import Box, Sphere
from skillbank.robots import UR5e, clearance
from skillbank.robots._clearance import _point_segment, segment_box_distance, segment_distance

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_of  # noqa: E402

OBSTACLES = {"ball": Sphere([-0.45, 0.35, 0.35], 0.08), "wall": Box([-0.2, -0.8, 0.0], [-0.15, -0.2, 0.5]),
             "post": Box([0.35, 0.3, 0.0], [0.45, 0.4, 0.6])}
TABLE = Box([-1.5, -1.5, -0.05], [1.5, 1.5, 0.0])
WORKSPACE = (np.array([-1.2, -1.2, -0.1]), np.array([1.2, 1.2, 1.4]))
NO_DENSIFY = 1e6


def trajectory(n: int, seed: int = 0) -> np.ndarray:
    """A smooth joint path about home: per joint, three sines of random amplitude, frequency and phase."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, n)[:, None]
    amplitude = rng.uniform(0.1, 0.6, (3, 6))
    frequency, phase = rng.uniform(0.5, 3.0, (3, 6)), rng.uniform(0, 2 * np.pi, (3, 6))
    wave = sum(amplitude[k] * np.sin(2 * np.pi * frequency[k] * s + phase[k]) for k in range(3))
    return np.asarray(UR5e.home) + wave


def _pairs(robot):
    """Every checked pair as (body, other), in the vectorised check's order."""
    return list(clearance(robot, robot.home, OBSTACLES, table=TABLE, workspace=WORKSPACE).per_pair)


def loop_clearance(robot, joints) -> np.ndarray:
    """``(n, n_pairs)`` distances, one sample and one pair at a time (the straightforward way)."""
    bodies = {c.name: c for c in robot.bodies}
    pairs = _pairs(robot)
    lower, upper = WORKSPACE
    out = np.empty((joints.shape[0], len(pairs)))
    for i, q in enumerate(joints):
        frames = robot.link_frames(q)[0]
        ends = {name: (frames[c.frame, :3, :3] @ np.asarray(c.a) + frames[c.frame, :3, 3],
                       frames[c.frame, :3, :3] @ np.asarray(c.b) + frames[c.frame, :3, 3])
                for name, c in bodies.items()}
        for k, (body, other) in enumerate(pairs):
            a, b = ends[body]
            r = bodies[body].radius
            if other in bodies:
                out[i, k] = float(segment_distance(a, b, *ends[other])) - r - bodies[other].radius
            elif other == "workspace":
                out[i, k] = min(min((p - lower).min(), (upper - p).min()) for p in (a, b)) - r
            else:
                o = TABLE if other == "table" else OBSTACLES[other]
                if isinstance(o, Sphere):
                    out[i, k] = float(_point_segment(a, b, o.center)) - r - o.radius
                else:
                    out[i, k] = float(segment_box_distance(a, b, o.lower, o.upper)) - r
    return out


def mujoco_model(robot):
    import mujoco  # the sim extra, only for this comparison

    bodies = []
    for c in robot.bodies:
        fromto = " ".join(repr(float(x)) for x in (*c.a, *c.b))
        bodies.append(f'<body name="{c.name}" mocap="true"><geom name="{c.name}" type="capsule" '
                      f'size="{c.radius!r}" fromto="{fromto}" contype="0" conaffinity="0"/></body>')
    for name, o in {**OBSTACLES, "table": TABLE}.items():
        if isinstance(o, Sphere):
            geom = f'type="sphere" size="{o.radius!r}" pos="{" ".join(map(repr, o.center.tolist()))}"'
        else:
            half, centre = (o.upper - o.lower) / 2, (o.upper + o.lower) / 2
            geom = (f'type="box" size="{" ".join(map(repr, half.tolist()))}" '
                    f'pos="{" ".join(map(repr, centre.tolist()))}"')
        bodies.append(f'<geom name="{name}" {geom} contype="0" conaffinity="0"/>')
    model = mujoco.MjModel.from_xml_string(f"<mujoco><worldbody>{''.join(bodies)}</worldbody></mujoco>")
    return mujoco, model, mujoco.MjData(model)


def mujoco_clearance(robot, joints, sim) -> np.ndarray:
    """``(n, n_pairs)`` MuJoCo distances (NaN for the workspace's pairs), one sample at a time."""
    mujoco, model, data = sim
    from skillbank.core._rotations import matrix_to_quaternion

    pairs = _pairs(robot)
    ids = [(model.geom(b).id, model.geom(o).id) if o != "workspace" else None for b, o in pairs]
    frame = np.array([c.frame for c in robot.bodies])
    F = robot.link_frames(joints)[:, frame]
    quat = matrix_to_quaternion(F[..., :3, :3].reshape(-1, 3, 3)).reshape(F.shape[0], -1, 4)
    quat = quat[..., [3, 0, 1, 2]]  # MuJoCo's quaternions are scalar-first
    out = np.full((joints.shape[0], len(pairs)), np.nan)
    for i in range(joints.shape[0]):
        data.mocap_pos[:] = F[i, :, :3, 3]
        data.mocap_quat[:] = quat[i]
        mujoco.mj_kinematics(model, data)
        for k, pair in enumerate(ids):
            if pair is not None:
                out[i, k] = mujoco.mj_geomDistance(model, data, pair[0], pair[1], 10.0, None)
    return out


def vectorised_table(robot, joints) -> np.ndarray:
    """The vectorised check's per-sample, per-pair distances (chunk by chunk, as it measures them)."""
    out = np.empty((joints.shape[0], len(_pairs(robot))))
    for i, q in enumerate(joints):
        result = clearance(robot, q, OBSTACLES, table=TABLE, workspace=WORKSPACE, max_move=NO_DENSIFY)
        out[i] = list(result.per_pair.values())
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=10_000)
    parser.add_argument("--loop-max", type=int, default=1000, help="samples the loops run on (then scaled)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="2,000 samples, loops on 200, one repeat")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    if args.quick:
        args.samples, args.loop_max, args.repeats = 2000, 200, 1
    robot = UR5e()
    joints = trajectory(args.samples)
    m = min(args.loop_max, args.samples)
    n_pairs = len(_pairs(robot))

    t_vec, result = best_of(lambda: clearance(robot, joints, OBSTACLES, table=TABLE, workspace=WORKSPACE,
                                              max_move=NO_DENSIFY), args.repeats)
    t_dense, dense = best_of(lambda: clearance(robot, joints, OBSTACLES, table=TABLE, workspace=WORKSPACE),
                             args.repeats)
    t_loop, loop = best_of(lambda: loop_clearance(robot, joints[:m]), 1)
    rows = [("vectorised", t_vec, args.samples, args.samples), ("vectorised, densified", t_dense,
                                                                  args.samples, dense.n_checked),
            ("per-sample loop", t_loop * args.samples / m, m, m)]
    disagreement = {}
    reference = vectorised_table(robot, joints[:m])
    disagreement["per-sample loop"] = float(np.abs(loop - reference).max())
    np.testing.assert_allclose(result.distance[:m], reference.min(axis=1), atol=1e-12)
    try:
        sim = mujoco_model(robot)
    except ImportError:
        print("MuJoCo not installed (pip install 'skillbank[sim]'): its row is left out")
    else:
        t_mj, theirs = best_of(lambda: mujoco_clearance(robot, joints[:m], sim), 1)
        rows.append(("MuJoCo mj_geomDistance", t_mj * args.samples / m, m, m))
        both = (reference > 0) & (theirs > 0)
        disagreement["MuJoCo mj_geomDistance"] = float(np.abs(reference - theirs)[both].max())
        same = ((reference < 1e-6) == (theirs < 1e-6)) | np.isnan(theirs)
        disagreement["MuJoCo overlaps agree"] = bool(same.all())

    print(f"whole-arm clearance, UR5e + 2F-85, {args.samples} samples x {n_pairs} pairs "
          f"({platform.processor() or platform.machine()})")
    print(f"{'method':28s} {'time (s)':>10s} {'per sample (us)':>16s} {'timed on':>9s} {'checked':>8s}")
    for name, seconds, timed, checked in rows:
        print(f"{name:28s} {seconds:10.4f} {seconds / args.samples * 1e6:16.2f} {timed:9d} {checked:8d}")
    print(f"smallest distance {result.min_distance:.4f} m, sample {result.index}, "
          f"{result.body} / {result.other}")
    for name, value in disagreement.items():
        print(f"largest disagreement, {name}: {value if isinstance(value, bool) else f'{value:.2e} m'}")
    speed = simulation_speed()
    if speed is not None:
        print(f"skillbank sim run: {speed['duration']:.1f} s of trajectory, real-time factor "
              f"{speed['real_time_factor']:.0f}x, command wall time {speed['wall']:.2f} s")
    if args.json:
        args.json.write_text(json.dumps({"samples": args.samples, "pairs": n_pairs, "simulation": speed,
                                         "rows": [dict(zip(("method", "seconds", "timed_on", "checked"), r,
                                                           strict=True)) for r in rows],
                                         "disagreement": disagreement, "clearance": result.to_dict()},
                                        indent=2))
    return 0


def simulation_speed():
    """The CLI's real-time factor on the embedded UR5e recording (None without MuJoCo)."""
    import subprocess  # noqa: PLC0415 - only this part runs a child
    import tempfile  # noqa: PLC0415
    import time  # noqa: PLC0415

    try:
        import mujoco  # noqa: F401, PLC0415 - the sim extra
    except ImportError:
        return None
    from skillbank.experiments import synthetic_ur5e  # noqa: PLC0415
    from skillbank.io import write_npz  # noqa: PLC0415

    demo = synthetic_ur5e()
    low = demo["position"][np.argmin(demo["position"][:, 2])]
    scene = {"objects": {"b1": {"type": "button", "position": [float(v) for v in low - [0, 0, 0.01]]}},
             "table": {"height": float(low[2]) - 0.1}, "goal": ["(pressed b1)"]}
    with tempfile.TemporaryDirectory() as tmp:
        traj, path = Path(tmp) / "traj.npz", Path(tmp) / "scene.json"
        write_npz(demo, traj)
        path.write_text(json.dumps(scene))
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-m", "skillbank.cli", "sim", "run", str(traj), "--scene",
                              str(path), "--json"], capture_output=True, text=True, check=False)
        wall = time.perf_counter() - t0
    if out.returncode not in (0, 1):
        raise RuntimeError(out.stderr)
    doc = json.loads(out.stdout)
    return {"duration": doc["duration"], "real_time_factor": doc["real_time_factor"], "wall": wall}


if __name__ == "__main__":
    sys.exit(main())
