"""Segmentation cost against the recording's length: the slope, the memory, and an hour-long bag.

Run from the repository root (the bag needs the extra ``ros``)::

    .venv/bin/python benchmarks/bench_segmentation_scale.py [--sizes 100000 300000 1000000 3000000 10000000]
        [--old-sizes 100000 200000 400000] [--bag-messages 1000000] [--seeds 0 1 2] [--json PATH]

Recordings (:func:`recording`, seeded): point-to-point minimum-jerk moves of 0.8-2 s with rests
of 0.2-0.8 s, 500 Hz, six joints, the flange position and a gripper that switches at a third of
the rests, 0.1 mrad of joint noise. Each size is segmented with skillbank's defaults in its own
process (``run_child``: wall time from the fit's start, and the process's peak resident memory
beyond the recording, which is built first): ``new`` is the default window (4 % of the
recording, at most the motion's time scale), ``old`` the window the default used to be (4 % of
the recording, given as ``window=N``), on the smaller sizes only (its cost is quadratic), and
the peer, ruptures ``Pelt(l2)`` (extra ``bench``) as ``bench_ruptures.py`` runs it: the streams'
velocities standardised side by side, penalty ``3 log(n) d``, minimum segment 0.2 s, a change
considered every :data:`RUPTURES_JUMP` samples.
Reported: seconds, microseconds per sample, peak memory, keypoints, true boundaries, the window,
and the recall of the true boundaries within 0.5 s.

Excerpt: for each seed, 20 minutes of motion and its first 5 minutes, each segmented on its own;
the window of each, keypoints per minute, and the share of the excerpt's keypoints that the whole
recording also has within one window (and the reverse).

Bag: a ROS 2 MCAP bag of ``--bag-messages`` messages (four in five ``sensor_msgs/JointState``
at 500 Hz, one in five ``geometry_msgs/PoseStamped`` at 125 Hz, written with rosbags' own
writer, the motion of :func:`recording`), then in child processes ``read_rosbag`` alone and
``skillbank segment BAG --json`` (what a user runs): the segmenting time is the difference.
No timing is asserted.
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
from _common import run_child  # noqa: E402

RATE = 500.0
#: ruptures considers a change every this many samples (its ``jump``): 20 ms at 500 Hz, finer than
#: the 0.5 s the recall allows, and a tenth of the candidates (and of its time) of every sample.
RUPTURES_JUMP = 10
_NS = 1_000_000_000
_T0 = 1_700_000_000 * _NS


def recording(n: int, *, seed: int = 0, rate: float = RATE):
    """``(t, joints, position, gripper, boundaries)``: moves and rests, ``n`` samples at ``rate`` Hz.

    The boundaries are the middles of the rests (s).
    """
    rng = np.random.default_rng(seed)
    q = np.empty((n, 6))
    g = np.empty(n)
    here, grip, i, ends = rng.uniform(-1, 1, 6), 0.0, 0, []
    while i < n:
        d, r = int(rng.uniform(0.8, 2.0) * rate), int(rng.uniform(0.2, 0.8) * rate)
        there = here + rng.uniform(-0.6, 0.6, 6)
        s = np.linspace(0.0, 1.0, d)
        b = 10 * s**3 - 15 * s**4 + 6 * s**5
        j, k = min(n, i + d), min(n, i + d + r)
        q[i:j] = (here + b[:, None] * (there - here))[: j - i]
        q[j:k] = there
        g[i:k] = grip
        if rng.random() < 1 / 3:
            grip = 1.0 - grip
        ends.append(0.5 * (j + k) / rate)  # the middle of the rest: where a cut belongs
        here, i = there, k
    q += rng.normal(0.0, 1e-4, q.shape)
    reach = 0.4 + 0.1 * np.cos(q[:, 1])
    x = np.column_stack([reach * np.cos(q[:, 0]), reach * np.sin(q[:, 0]), 0.3 + 0.1 * np.sin(q[:, 2])])
    return np.arange(n) / rate, q, x, g[:, None], np.array(ends[:-1])


_FIT = """
import json, resource, sys, time
sys.path.insert(0, {bench!r})
import numpy as np
from bench_segmentation_scale import recording
from skillbank import Demonstration
from skillbank.segmentation import segment
t, q, x, g, truth = recording({n}, seed={seed})
demo = Demonstration(t, {{"joints": q, "position": x, "gripper": g}})
del q, x, g
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
start = time.perf_counter()
result = segment(demo, **{params!r})
seconds = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
kp = result.keypoint_times
hit = np.abs(kp[:, None] - truth[None, :]).min(axis=0) < 0.5 if kp.size and truth.size else np.zeros(0, bool)
print(json.dumps({{"seconds": seconds, "peak_beyond_mb": peak - before, "keypoints": int(kp.size),
                  "truth": int(truth.size), "recall": float(hit.mean()) if hit.size else 0.0,
                  "window": int(result.streams["joints"].params["window"])}}))
"""


_RUPTURES = """
import json, resource, sys, time
sys.path.insert(0, {bench!r})
import numpy as np
import ruptures
from bench_segmentation_scale import recording
t, q, x, g, truth = recording({n}, seed={seed})
# what ruptures is given in bench_ruptures.py: each stream's velocity, standardised, side by side
signal = np.column_stack([np.gradient(q, t, axis=0), np.gradient(x, t, axis=0), g])
signal = (signal - signal.mean(axis=0)) / signal.std(axis=0)
del q, x, g
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
start = time.perf_counter()
bkps = ruptures.Pelt(model="l2", min_size=int(0.2 * {rate}), jump={jump}).fit(signal).predict(
    pen=3 * np.log({n}) * signal.shape[1])
seconds = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
kp = np.asarray(bkps[:-1], float) / {rate}
hit = np.abs(kp[:, None] - truth[None, :]).min(axis=0) < 0.5 if kp.size else np.zeros(0, bool)
print(json.dumps({{"seconds": seconds, "peak_beyond_mb": peak - before, "keypoints": int(kp.size),
                  "truth": int(truth.size), "recall": float(hit.mean()) if hit.size else 0.0,
                  "window": None}}))
"""


def fit_child(n: int, seed: int, params: dict, *, peer: bool = False) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out.json"
        bench = str(Path(__file__).resolve().parent)
        code = (_RUPTURES.format(bench=bench, n=n, seed=seed, rate=RATE, jump=RUPTURES_JUMP) if peer
                else _FIT.format(bench=bench, n=n, seed=seed, params=params))
        run = run_child([sys.executable, "-c", code], stdout=out)
        if run.returncode:
            raise RuntimeError(run.stderr.strip().splitlines()[-1:])
        row = json.loads(out.read_text())
    row.update(n=n, seed=seed, us_per_sample=round(1e6 * row["seconds"] / n, 2),
               seconds=round(row["seconds"], 2), peak_beyond_mb=round(row["peak_beyond_mb"]),
               recall=round(row["recall"], 3))
    return row


def excerpt(seed: int) -> dict:
    from skillbank import Demonstration
    from skillbank.segmentation import segment

    t, q, x, g, _ = recording(int(20 * 60 * RATE), seed=seed)
    whole = Demonstration(t, {"joints": q, "position": x, "gripper": g})
    part = whole.slice(0, int(5 * 60 * RATE))
    a, b = segment(whole), segment(part)
    wa, wb = a.streams["joints"].params["window"], b.streams["joints"].params["window"]
    end = 300.0 - wa / RATE  # a cut within a window of the excerpt's end can move
    ka, kb = a.keypoint_times[a.keypoint_times < end], b.keypoint_times[b.keypoint_times < end]
    tol = max(wa, wb) / RATE

    def share(x, y):
        if not (x.size and y.size):
            return 0.0
        return float(np.mean(np.abs(x[:, None] - y[None, :]).min(axis=1) <= tol))

    return {"seed": seed, "window_whole": int(wa), "window_excerpt": int(wb),
            "per_minute_whole": round(a.keypoint_times.size / 20, 1),
            "per_minute_excerpt": round(kb.size / 5, 1),
            "excerpt_in_whole": round(share(kb, ka), 3), "whole_in_excerpt": round(share(ka, kb), 3)}


def write_bag(folder: Path, n_messages: int, seed: int = 0) -> tuple[Path, float]:
    """JointState at 500 Hz and PoseStamped at 125 Hz (4 : 1), the motion of :func:`recording`."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.LATEST)
    T = ts.types
    n_joint = n_messages * 4 // 5
    t, q, x, _, _ = recording(n_joint, seed=seed)
    names = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
             "wrist_3_joint"]
    empty = np.array([], dtype=float)
    path = folder / "hour"
    js, ps = "sensor_msgs/msg/JointState", "geometry_msgs/msg/PoseStamped"

    def header(ns):
        stamp = T["builtin_interfaces/msg/Time"](sec=ns // _NS, nanosec=ns % _NS)
        return T["std_msgs/msg/Header"](stamp=stamp, frame_id="base")

    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        cj = writer.add_connection("/joint_states", js, typestore=ts)
        cp = writer.add_connection("/tool_pose", ps, typestore=ts)
        for k in range(n_joint):
            ns = _T0 + k * 2_000_000
            writer.write(cj, ns, ts.serialize_cdr(T[js](header=header(ns), name=names, position=q[k],
                                                        velocity=empty, effort=empty), js))
            if k % 4 == 0:
                pose = T["geometry_msgs/msg/Pose"](
                    position=T["geometry_msgs/msg/Point"](x=x[k, 0], y=x[k, 1], z=x[k, 2]),
                    orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))
                writer.write(cp, ns, ts.serialize_cdr(T[ps](header=header(ns), pose=pose), ps))
    return path, float(t[-1])


def bench_bag(n_messages: int, folder: Path) -> dict:
    start = time.perf_counter()
    path, seconds = write_bag(folder, n_messages)
    written = time.perf_counter() - start
    out = {"messages": n_messages, "motion_s": round(seconds), "write_s": round(written, 1)}
    code = f"from skillbank.io import read_rosbag; read_rosbag({str(path)!r})"
    read = run_child([sys.executable, "-c", code])
    if read.returncode:
        raise RuntimeError(read.stderr.strip().splitlines()[-1:])
    cli = Path(sys.executable).parent / "skillbank"
    with tempfile.TemporaryDirectory() as tmp:
        res = Path(tmp) / "out.json"
        seg = run_child([cli, "segment", path, "--json"], stdout=res)
        if seg.returncode:
            raise RuntimeError(seg.stderr.strip().splitlines()[-1:])
        doc = json.loads(res.read_text())
    kp = doc.get("keypoint_times", doc.get("keypoints", []))
    out.update(read_s=round(read.seconds, 1), read_peak_mb=round(read.max_rss_mb),
               segment_cli_s=round(seg.seconds, 1), segment_cli_peak_mb=round(seg.max_rss_mb),
               segmenting_s=round(seg.seconds - read.seconds, 1), keypoints=len(kp),
               keypoints_per_minute=round(len(kp) / (seconds / 60), 1))
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", type=int, nargs="+",
                   default=[100_000, 300_000, 1_000_000, 3_000_000, 10_000_000])
    p.add_argument("--old-sizes", type=int, nargs="*", default=[100_000, 200_000, 400_000])
    p.add_argument("--ruptures-sizes", type=int, nargs="*", default=[100_000, 200_000, 400_000],
                   help="sizes for ruptures Pelt(l2) (the bench extra); none: skip it")
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    p.add_argument("--bag-messages", type=int, default=1_000_000, help="0: no bag")
    p.add_argument("--json", type=Path, default=None)
    args = p.parse_args(argv)
    report = {"machine": platform.processor() or platform.machine(), "python": platform.python_version(),
              "new": [], "old": [], "excerpt": []}
    for n in args.sizes:
        row = fit_child(n, args.seeds[0], {})
        report["new"].append(row)
        print("new", row, flush=True)
    for n in args.old_sizes:
        row = fit_child(n, args.seeds[0], {"window": int(round(0.04 * n))})
        report["old"].append(row)
        print("old", row, flush=True)
    report["ruptures"] = []
    for n in args.ruptures_sizes:
        row = fit_child(n, args.seeds[0], {}, peer=True)
        report["ruptures"].append(row)
        print("ruptures Pelt(l2)", row, flush=True)
    for seed in args.seeds:
        row = excerpt(seed)
        report["excerpt"].append(row)
        print("excerpt", row, flush=True)
    if args.bag_messages:
        with tempfile.TemporaryDirectory() as tmp:
            report["bag"] = bench_bag(args.bag_messages, Path(tmp))
            print("bag", report["bag"], flush=True)
    new = report["new"]
    if len(new) >= 2:
        sizes, times = [r["n"] for r in new], [max(r["seconds"], 1e-3) for r in new]
        slope = np.polyfit(np.log(sizes), np.log(times), 1)[0]
        report["slope_new"] = round(float(slope), 2)
        print(f"time ~ n^{slope:.2f}")
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
