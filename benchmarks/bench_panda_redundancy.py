"""How far a recorded Panda's joints follow from its tool poses: the 7th joint's freedom (issue 28, item 5).

Run from the repository root::

    .venv/bin/python benchmarks/bench_panda_redundancy.py [--tasks Lift Stack] [--seeds 0 1 2]
        [--episodes 3] [--json PATH]

Case: ``skillbank sim record robosuite:TASK --robot Panda`` episodes (robosuite's operational-space
controller, OSC_POSE, tracks the scripted demonstrator's tool goals at 20 Hz). A 7-joint arm has a
one-parameter family of joints per tool pose; which one the recording went through is decided by the
controller's dynamics, not by the poses. Each rule below is given the recorded tool poses and the
first sample's joints only, and its joints are compared with the recorded ones (the largest
difference over the episode's samples and joints, radians):

- **seeded IK**: ``robot_model("panda").ik(P, Q, q_seed=q[0])``, skillbank's path IK (the null space
  pulled to the seed and away from the limits);
- **quasi-static**: the joints on each pose nearest the first sample in the arm's mass-matrix metric,
  ``min (q - q0)' M(q) (q - q0)``: where robosuite's null-space pull
  (``N' M (kp (q0 - q) - kv qdot)``, ``kp`` 10) comes to rest when the tool stands still;
- **dynamic**: the same pull integrated along the recording by Gauss's principle of least constraint:
  the task-space controller acts through ``J'F`` (a constraint force), so the joints at each substep
  are the ones on the recorded pose (interpolated, 10 substeps a sample) nearest, in ``M``, to where
  the null-space pull alone would carry them (``q + h qdot + h^2 (kp (q0 - q) - kv qdot)``).

``M`` is robosuite's own (its simulated Panda with the gripper and the armature robosuite adds), read
with ``mj_fullM``: these two rules are analyses of what a model of the recording controller can
recover, not something the description alone gives. The episodes are then replayed in robosuite (the
recorded states and actions reproduce the joints to 2e-4 rad) with the controller's torques logged:
**saturated steps** counts the control steps in which the controller asked a joint for more than its
motor's limit (the MJCF's ``ctrlrange``: 80 N m on joints 1-5, 12 N m on 6-7), which the actuator then
clips. A clipped torque has a null-space part the controller never commanded, so no rule that sees
poses alone follows the joints through it. Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from skillbank.core import quaternion_to_matrix, slerp
from skillbank.robots import robot_model
from skillbank.robots._chain import rotation_error

KP_NULL = 10.0  # robosuite's nullspace_torques default gain
SUBSTEPS = 10


def _project(model, q_hat, p, quat, W, start=None, iterations=30):
    """The joints at the tool pose ``p``, ``quat`` nearest q_hat in the metric W (Newton steps on the
    linearised pose, from start)."""
    q = (q_hat if start is None else start).copy()
    W_inv = np.linalg.inv(W)
    R = quaternion_to_matrix(quat)
    for _ in range(iterations):
        p_now, quat_now = model.fk(q)
        J = model.jacobian(q)[0]
        e = np.concatenate([p - p_now, rotation_error(R, quaternion_to_matrix(quat_now))])
        r = q - q_hat
        delta = -r + W_inv @ J.T @ np.linalg.solve(J @ W_inv @ J.T, e + J @ r)
        q = q + delta
        if np.abs(delta).max() < 1e-12:
            break
    return q


def _rules(model, mass, q, P, Q, dt):
    q0 = q[0]
    quasi = [q0]
    for k in range(1, len(P)):
        quasi.append(_project(model, q0, P[k], Q[k], mass(quasi[-1]), start=quasi[-1]))
    kv = 2.0 * np.sqrt(KP_NULL)
    qk, vk, dynamic = q0.copy(), np.zeros_like(q0), [q0]
    h = dt / SUBSTEPS
    # the recorded poses at every substep: positions along straight lines, orientations by SLERP
    t = np.arange(len(P)) * dt
    t_sub = np.arange(1, (len(P) - 1) * SUBSTEPS + 1) * h
    P_sub = np.column_stack([np.interp(t_sub, t, P[:, i]) for i in range(3)])
    Q_sub = slerp(t, Q, t_sub)
    for j in range(len(t_sub)):
        q_hat = qk + h * vk + h * h * (KP_NULL * (q0 - qk) - kv * vk)
        qn = _project(model, q_hat, P_sub[j], Q_sub[j], mass(qk))
        vk, qk = (qn - qk) / h, qn
        if (j + 1) % SUBSTEPS == 0:
            dynamic.append(qk.copy())
    return np.array(quasi), np.array(dynamic)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--tasks", nargs="+", default=["Lift", "Stack"])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)

    import h5py
    import mujoco
    import robosuite as suite

    from skillbank.simulation import record

    rows = []
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for task in args.tasks:
            env = suite.make(task, robots=["Panda"], has_renderer=False, has_offscreen_renderer=False,
                             use_camera_obs=False, control_freq=20, ignore_done=True)
            env.reset()
            arm = env.robots[0]
            ctrl = arm.composite_controller.part_controllers["right"]
            m, d = env.sim.model._model, env.sim.data._data
            qi, vi = np.array(arm._ref_joint_pos_indexes), np.array(arm._ref_joint_vel_indexes)

            def mass(q, m=m, d=d, qi=qi, vi=vi):
                d.qpos[qi] = q
                mujoco.mj_forward(m, d)
                M = np.zeros((m.nv, m.nv))
                mujoco.mj_fullM(m, M, d.qM)
                return M[np.ix_(vi, vi)]

            excess = []
            run = ctrl.run_controller

            def logged(run=run, ctrl=ctrl, excess=excess):
                torques = run()
                over = np.maximum(torques - ctrl.actuator_max, ctrl.actuator_min - torques)
                excess.append(float(over.max()))
                return torques

            for seed in args.seeds:
                out = Path(tmp) / f"{task}_{seed}.h5"
                record(f"robosuite:{task}", episodes=args.episodes, out=out, seed=seed, robot="Panda")
                with h5py.File(out) as h5:
                    frames = json.loads(h5["data"].attrs["robot"])
                    model = robot_model("panda", base=np.array(frames["base"]), tool=np.array(frames["tool"]))
                    for i in range(len(h5["data"])):
                        g = h5[f"data/demo_{i}"]
                        q = g["obs/robot0_joint_pos"][:]
                        P, Q = g["obs/robot0_eef_pos"][:], g["obs/robot0_eef_quat"][:]
                        seeded = model.ik(P, Q, q_seed=q[0])
                        quasi, dynamic = _rules(model, mass, q, P, Q, 1.0 / 20)
                        # replay with the torques logged: which control steps asked beyond the motors
                        env.sim.set_state_from_flattened(g["states"][0])
                        env.sim.forward()
                        ctrl.update_initial_joints(q[0])
                        ctrl.reset_goal()
                        ctrl.run_controller = logged
                        saturated, replay_error = 0, 0.0
                        for k, action in enumerate(g["actions"][:-1]):
                            excess.clear()
                            env.step(action)
                            saturated += max(excess) > 0
                            replay_error = max(replay_error, float(np.abs(d.qpos[qi] - q[k + 1]).max()))
                        ctrl.run_controller = run
                        row = {"task": task, "seed": seed, "episode": i, "samples": len(q),
                               "saturated_steps": int(saturated), "replay_error": replay_error,
                               **{name: float(np.abs(v - q).max()) for name, v in
                                  (("seeded", seeded), ("quasi_static", quasi), ("dynamic", dynamic))}}
                        rows.append(row)
                        print(json.dumps(row), flush=True)
            env.close()
    print("\n| task | seed | episode | saturated steps | seeded IK | quasi-static | dynamic |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['task']} | {r['seed']} | {r['episode']} | {r['saturated_steps']} | {r['seeded']:.3f} | "
              f"{r['quasi_static']:.3f} | {r['dynamic']:.4f} |")
    clean = [r for r in rows if r["saturated_steps"] == 0]
    for label, group in (("all episodes", rows), ("no saturated step", clean),
                         ("some saturated step", [r for r in rows if r["saturated_steps"]])):
        if group:
            d = np.array([r["dynamic"] for r in group])
            print(f"{label}: {len(group)} episodes; dynamic within 0.01 rad in {int((d < 0.01).sum())}, "
                  f"median {np.median(d):.4f}, worst {d.max():.4f}")
    print(f"wall time {time.perf_counter() - started:.0f} s; {platform.processor() or platform.machine()}")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
