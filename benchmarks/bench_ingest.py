"""Benchmark of reading what labs record: a large ROS bag, and a LeRobot dataset of many episodes.

Run from the repository root (needs the extras ``ros`` and ``lerobot``)::

    .venv/bin/python benchmarks/bench_ingest.py [--messages 1000000] [--storage mcap ros1]
        [--episodes 1000] [--frames 100] [--json PATH]

Bag: ``--messages`` messages, five in six ``sensor_msgs/JointState`` (six
joints, 500 Hz) and one in six ``geometry_msgs/WrenchStamped`` (100 Hz),
written with rosbags' own writer. Each reading runs in its own process, timed
with its start-up and its peak resident memory (``run_child``):

- ``plain``: a loop over ``AnyReader.messages`` that decodes every message
  with rosbags' deserialiser and keeps nothing, the floor for any reader
  built on rosbags;
- ``keep``: the same loop keeping every decoded message in a list, what a
  reader that loads a bag whole holds;
- ``skillbank``: ``skillbank.io.read_rosbag`` with its defaults (decode,
  keep the numbers in growing arrays, align onto the joints' clock).

Messages per second are the bag's messages over the child's wall time. A
LeRobot v3.0 dataset of ``--episodes`` episodes of ``--frames`` frames
(state 6, action 6, float32; 100 episodes per data file) is then read whole
with ``read_lerobot``, best of 3, in this process, and added to a new library
(``Library.add_files`` with ``observation.state`` as the position, whole
episodes, one transaction). No timing is asserted.
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

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_of, run_child  # noqa: E402

_NS = 1_000_000_000
_T0 = 1_700_000_000 * _NS

_CHILD = {
    "plain": """
from pathlib import Path
from rosbags.highlevel import AnyReader
with AnyReader([Path({path!r})]) as reader:
    for conn, log, raw in reader.messages(connections=reader.connections):
        reader.deserialize(raw, conn.msgtype)
""",
    "keep": """
from pathlib import Path
from rosbags.highlevel import AnyReader
kept = []
with AnyReader([Path({path!r})]) as reader:
    for conn, log, raw in reader.messages(connections=reader.connections):
        kept.append(reader.deserialize(raw, conn.msgtype))
""",
    "skillbank": """
from skillbank.io import read_rosbag
read_rosbag({path!r})
""",
}


def write_bag(folder: Path, storage: str, n_messages: int) -> Path:
    """A bag of JointState (500 Hz) and WrenchStamped (100 Hz) messages, written by rosbags."""
    from rosbags.rosbag1 import Writer as Ros1Writer
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Ros2Writer
    from rosbags.typesys import Stores, get_typestore

    ros1 = storage == "ros1"
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.LATEST)
    types = ts.types
    header_type, time_type = types["std_msgs/msg/Header"], types["builtin_interfaces/msg/Time"]
    vector = types["geometry_msgs/msg/Vector3"]

    def header(ns):
        stamp = time_type(sec=ns // _NS, nanosec=ns % _NS)
        return header_type(seq=0, stamp=stamp, frame_id="") if ros1 else header_type(stamp=stamp, frame_id="")

    names = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
             "wrist_3_joint"]
    empty = np.array([], dtype=float)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / ("bench.bag" if ros1 else "bench")
    writer = Ros1Writer(path) if ros1 else Ros2Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
    serialise = ts.serialize_ros1 if ros1 else ts.serialize_cdr
    joint_type, wrench_type = "sensor_msgs/msg/JointState", "geometry_msgs/msg/WrenchStamped"
    with writer:
        joints = writer.add_connection("/joint_states", joint_type, typestore=ts)
        wrench = writer.add_connection("/ft", wrench_type, typestore=ts)
        for k in range(n_messages):
            block, j = divmod(k, 6)  # every 10 ms: five joint states 2 ms apart, then one wrench
            ns = _T0 + block * 10_000_000 + (j * 2_000_000 if j < 5 else 9_000_000)
            if j == 5:
                msg = types[wrench_type](header=header(ns), wrench=types["geometry_msgs/msg/Wrench"](
                    force=vector(x=k * 1e-6, y=0.0, z=1.0), torque=vector(x=0.0, y=0.0, z=0.0)))
                writer.write(wrench, ns, serialise(msg, wrench_type))
            else:
                msg = types[joint_type](header=header(ns), name=names, position=np.full(6, k * 1e-6),
                                        velocity=empty, effort=empty)
                writer.write(joints, ns, serialise(msg, joint_type))
    return path


def bench_bag(storage: str, n_messages: int, folder: Path) -> dict:
    start = time.perf_counter()
    path = write_bag(folder, storage, n_messages)
    written = time.perf_counter() - start
    size = sum(f.stat().st_size for f in ([path] if path.is_file() else path.iterdir()))
    out = {"storage": storage, "messages": n_messages, "bag_mb": round(size / 2**20, 1),
           "write_s": round(written, 1)}
    for mode, code in _CHILD.items():
        run = run_child([sys.executable, "-c", code.format(path=str(path))])
        if run.returncode:
            raise RuntimeError(f"{mode} failed: {run.stderr.strip().splitlines()[-1:]}")
        out[mode] = {"seconds": round(run.seconds, 2), "messages_per_s": round(n_messages / run.seconds),
                     "peak_rss_mb": round(run.max_rss_mb, 1)}
    out["skillbank_over_plain"] = round(out["plain"]["seconds"] / out["skillbank"]["seconds"], 2)
    return out


def write_lerobot(root: Path, n_episodes: int, frames: int, per_file: int = 100) -> Path:
    """A LeRobot v3.0 dataset: state and action (6 floats each), ``per_file`` episodes per data file."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    kind = pa.list_(pa.float32(), 6)
    features = {k: {"dtype": "float32", "shape": [6], "names": None} for k in ("observation.state", "action")}
    info = {"codebase_version": "v3.0", "fps": 30, "features": features,
            "data_path": "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"}
    (root / "meta" / "episodes" / "chunk-000").mkdir(parents=True)
    (root / "meta" / "info.json").write_text(json.dumps(info))
    rows, rng = [], np.random.default_rng(0)
    for f in range(0, n_episodes, per_file):
        episodes = range(f, min(f + per_file, n_episodes))
        n = frames * len(episodes)
        state = rng.standard_normal((n, 6)).astype(np.float32)
        table = pa.table({"observation.state": pa.array(list(state), type=kind),
                          "action": pa.array(list(-state), type=kind),
                          "frame_index": np.tile(np.arange(frames), len(episodes)),
                          "episode_index": np.repeat(np.array(episodes), frames)})
        path = root / info["data_path"].format(chunk_index=0, file_index=f // per_file)
        path.parent.mkdir(parents=True, exist_ok=True)
        pq.write_table(table, path)
        rows += [{"episode_index": e, "length": frames, "tasks": ["reach"], "data/chunk_index": 0,
                  "data/file_index": f // per_file} for e in episodes]
    pq.write_table(pa.Table.from_pylist(rows), root / "meta" / "episodes" / "chunk-000" / "file-000.parquet")
    return root


def bench_lerobot(n_episodes: int, frames: int, folder: Path) -> dict:
    from skillbank.io import read_lerobot
    from skillbank.pipeline import Library

    root = write_lerobot(folder / "lerobot", n_episodes, frames)
    seconds, demos = best_of(lambda: read_lerobot(root), 3)

    def into_library(k=[0]):  # noqa: B006  a fresh library file per repeat
        k[0] += 1
        with Library(folder / f"lib{k[0]}.sqlite", create=True) as lib:
            return lib.add_files([root], reader_options={"features": ["observation.state=position"]},
                                 segment=False, assign="none")

    added_s, report = best_of(into_library, 3)
    return {"episodes": n_episodes, "frames_per_episode": frames, "seconds": round(seconds, 3),
            "episodes_per_s": round(n_episodes / seconds), "read": len(demos),
            "library_add_s": round(added_s, 3), "added": len(report["demonstrations"])}


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--messages", type=int, default=1_000_000)
    parser.add_argument("--storage", nargs="+", default=["mcap", "ros1"], choices=["mcap", "ros1"])
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    import rosbags  # noqa: F401  fail early without the extras

    report = {"python": platform.python_version(), "machine": platform.machine(), "bags": []}
    with tempfile.TemporaryDirectory() as tmp:
        for storage in args.storage:
            row = bench_bag(storage, args.messages, Path(tmp) / storage)
            report["bags"].append(row)
            print(f"{storage}: {row['messages']} messages ({row['bag_mb']} MB, written in "
                  f"{row['write_s']} s)")
            for mode in _CHILD:
                r = row[mode]
                print(f"  {mode:9s} {r['seconds']:7.2f} s  {r['messages_per_s']:9d} msg/s  "
                      f"peak RSS {r['peak_rss_mb']:7.1f} MB")
            print(f"  plain / skillbank time: {row['skillbank_over_plain']}")
        report["lerobot"] = bench_lerobot(args.episodes, args.frames, Path(tmp))
        lr = report["lerobot"]
        print(f"LeRobot v3.0: {lr['episodes']} episodes x {lr['frames_per_episode']} frames read in "
              f"{lr['seconds']} s ({lr['episodes_per_s']} episodes/s); into a library (one transaction, "
              f"whole episodes) in {lr['library_add_s']} s ({lr['added']} demonstrations)")
    if args.json is not None:
        args.json.write_text(json.dumps(report, indent=2))
    return report


if __name__ == "__main__":
    main()
