"""Benchmark of skillbank's segmentation against the per-sample loop baseline.

Run from the repository root::

    .venv/bin/python benchmarks/bench_segmentation.py [--quick] [--json PATH] [--roundoff]
    .venv/bin/python benchmarks/bench_segmentation.py --sweep [--sweep-seeds 80] [--json PATH]

Cases
-----
The loop baseline implements the paper's product rule, so skillbank is timed
against it with ``combine="product"`` (same method, same keypoints); the
column ``defaults s`` times skillbank's default evidence combination on the
same case, for reference.

three-button
    Full multimodal segmentation of ``seed/three_button_pressing_demo.h5``,
    streams joints, position, force, gripper (4099 samples, default parameters).
synthetic-N
    One 3-D synthetic stream of N = 10^4, 10^5, 10^6 samples: rest-to-rest
    minimum-jerk moves between random corners plus a smooth random-walk
    wiggle, on an uneven time axis (sample period varying smoothly by +-20 %
    around 1 ms). The window is fixed at 100 samples, so that both
    implementations do O(N) work and per-sample costs can be compared across N
    (the default window, 4 % of N, would make the loop baseline O(N^2)).
r-demos
    All five demonstrations of ``seed/r_shape.h5`` (group "normalized"), one
    after the other, default parameters.

With ``--roundoff``, also: the synthetic motion at 10^4, 10^5 and 10^6 samples
(seeds 0, 1, 2), segmented at full precision and as a copy with every value
and time stamp rounded to 12 significant digits (what a CSV written with
``%.12g`` holds), with default parameters: both copies' keypoints, whether
they agree within one window, the stride the jerk was taken over, the time,
and how much of each copy's single-sample jerk is round-off (median of
|jerk(copy) - jerk(exact)| over the median |jerk(exact)|).

With ``--sweep`` (and nothing timed): the same comparison over seeds 0 to
``--sweep-seeds`` - 1 of the same motion, with 7 corners (the motion of
``tests/segmentation/test_roundoff_cuts.py``), for 12 digits at 10^4 and
10^5 samples and 8 digits at 10^4: in how many seeds the keypoints agree
within one window (and there are at least 3), which seeds differ, and in how
many the two copies' jerk was taken over the same stride.

Every figure is the best of several repeats (``time.perf_counter``). The loop
baseline is timed in the same run; at 10^5 and 10^6 samples it runs once, and
only when its estimate (per-sample cost measured at 10^4 samples x N) is under
60 s and ``--quick`` is not given; otherwise the estimate is reported, marked
``~`` and ``(extrapolated)`` in the table. No timing is asserted anywhere.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
from pathlib import Path

import numpy as np
import scipy
from scipy.interpolate import CubicSpline

from skillbank import Demonstration
from skillbank.io import read_handwriting_h5, read_robot_h5
from skillbank.segmentation import jerk, segment

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_of, data_dir  # noqa: E402
from _loop_segmentation import loop_segment  # noqa: E402

# the loop baseline is the paper's product rule: skillbank is timed against it in the same mode
PRODUCT = {"combine": "product"}
THREE_BUTTON_STREAMS = ["joints", "position", "force", "gripper"]
SYNTHETIC_WINDOW = 100
LOOP_BUDGET_S = 60.0




def synthetic_demo(n: int, *, seed: int = 0, n_corners: int = 5) -> Demonstration:
    """A smooth 3-D path of ``n`` samples with ``n_corners`` stops, on an uneven clock."""
    rng = np.random.default_rng(seed)
    i = np.arange(n, dtype=float)
    # sample period 1 ms +- 20 %, varying smoothly (about 7 cycles over the demo)
    period = 0.001 * (1.0 + 0.2 * np.sin(2 * np.pi * 7.0 * i / n + 0.3))
    t = np.concatenate(([0.0], np.cumsum(period[:-1])))
    # rest-to-rest minimum-jerk moves through the corners
    corners = rng.normal(size=(n_corners + 2, 3))
    s = (t - t[0]) / (t[-1] - t[0]) * (len(corners) - 1)
    k = np.minimum(s.astype(int), len(corners) - 2)
    tau = s - k
    blend = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
    path = corners[k] + blend[:, None] * (corners[k + 1] - corners[k])
    # smooth random-walk wiggle: a cubic spline through a coarse random walk
    knots = np.linspace(t[0], t[-1], 60)
    walk = np.cumsum(rng.normal(scale=0.02, size=(knots.size, 3)), axis=0)
    path += CubicSpline(knots, walk)(t)
    return Demonstration(t, {"position": path})




def written(x, digits: int = 12) -> np.ndarray:
    """``x`` as a CSV written with ``%.<digits>g`` holds it."""
    x = np.asarray(x, dtype=float)
    return np.array([float(f"{v:.{digits}g}") for v in x.ravel()]).reshape(x.shape)


def roundoff_rows(sizes=(10_000, 100_000, 1_000_000), seeds=(0, 1, 2)) -> list:
    """Full precision against a 12-significant-digit copy of the same synthetic motion."""
    rows = []
    for n in sizes:
        for seed in seeds:
            demo = synthetic_demo(n, seed=seed)
            copy = Demonstration(written(demo.t), {"position": written(demo["position"])})
            full_s, full = best_of(lambda d=demo: segment(d), 1)
            copy_s, cut = best_of(lambda d=copy: segment(d), 1)
            window = full.streams["position"].params["window"]
            exact = np.linalg.norm(jerk(demo.t, demo["position"]), axis=1)
            noisy = np.linalg.norm(jerk(copy.t, copy["position"]), axis=1)
            agree = full.keypoints.size == cut.keypoints.size and bool(
                full.keypoints.size == 0 or np.abs(full.keypoints - cut.keypoints).max() <= window)
            rows.append({"n_samples": n, "seed": seed, "window": window,
                         "keypoints_full": full.keypoints.tolist(),
                         "keypoints_12_digits": cut.keypoints.tolist(),
                         "agree_within_window": agree,
                         "step_full": full.streams["position"].jerk_step,
                         "step_12_digits": cut.streams["position"].jerk_step,
                         "seconds_full": full_s, "seconds_12_digits": copy_s,
                         "jerk_roundoff": float(np.median(np.abs(noisy - exact)) / np.median(exact))})
    return rows


#: The sweep's cases: (samples, significant digits of the copy).
SWEEP_CASES = ((10_000, 12), (100_000, 12), (10_000, 8))


def roundoff_sweep(n_seeds: int = 80, cases=SWEEP_CASES) -> list:
    """Per case, over seeds ``0 .. n_seeds - 1``: full precision against a copy at so many digits."""
    rows = []
    for n, digits in cases:
        differ, same_stride = [], 0
        for seed in range(n_seeds):
            demo = synthetic_demo(n, seed=seed)
            copy = Demonstration(written(demo.t, digits), {"position": written(demo["position"], digits)})
            full, cut = segment(demo), segment(copy)
            window = full.streams["position"].params["window"]
            agree = full.keypoints.size >= 3 and full.keypoints.size == cut.keypoints.size and bool(
                np.abs(full.keypoints - cut.keypoints).max() <= window)
            if not agree:
                differ.append(seed)
            same_stride += full.streams["position"].jerk_step == cut.streams["position"].jerk_step
        rows.append({"n_samples": n, "digits": digits, "seeds": n_seeds, "agree": n_seeds - len(differ),
                     "differ": differ, "same_stride": int(same_stride)})
    return rows


def sweep_report(rows: list) -> str:
    lines = ["full precision against copies with fewer significant digits, keypoints within one window "
             "(default parameters, 7 corners):",
             f"{'n':>8} {'digits':>6} {'agree':>9} {'same stride':>12}  seeds that differ"]
    for r in rows:
        lines.append(f"{r['n_samples']:>8} {r['digits']:>6} {r['agree']:>4} / {r['seeds']:<3} "
                     f"{r['same_stride']:>5} / {r['seeds']:<4}  {r['differ'] or '-'}")
    return "\n".join(lines)


def roundoff_report(rows: list) -> str:
    lines = ["", "full precision against the same motion at 12 significant digits (default parameters):",
             f"{'n':>8} {'seed':>4} {'jerk round-off':>14} {'stride':>7} {'s full':>7} {'s copy':>7}  "
             "keypoints (full | 12 digits)"]
    for r in rows:
        lines.append(f"{r['n_samples']:>8} {r['seed']:>4} {r['jerk_roundoff']:>14.3g} "
                     f"{r['step_full']:>3}|{r['step_12_digits']:<3} {r['seconds_full']:>7.3f} "
                     f"{r['seconds_12_digits']:>7.3f}  {r['keypoints_full']} | {r['keypoints_12_digits']}"
                     + ("" if r["agree_within_window"] else "  DIFFER"))
    agree = sum(r["agree_within_window"] for r in rows)
    lines.append(f"keypoints agree within one window in {agree} of {len(rows)} cases")
    return "\n".join(lines)


def _row(case, n, fast_s, loop_s, extrapolated, fast_kp, loop_kp, note=""):
    return {"case": case, "n_samples": int(n), "skillbank_s": fast_s, "baseline_s": loop_s,
            "baseline_extrapolated": extrapolated, "speedup": loop_s / fast_s,
            "keypoints_skillbank": fast_kp, "keypoints_baseline": loop_kp, "note": note}


def run(quick: bool) -> dict:
    fast_repeats = 3 if quick else 7
    loop_repeats = 1 if quick else 3
    root = data_dir()
    rows = []

    # (a) three-button, 4 streams
    demo = read_robot_h5(root / "seed" / "three_button_pressing_demo.h5")
    segment(demo, THREE_BUTTON_STREAMS)  # warm-up (imports, caches)
    fast_s, fast = best_of(lambda: segment(demo, THREE_BUTTON_STREAMS, **PRODUCT), fast_repeats)
    defaults_s = [best_of(lambda: segment(demo, THREE_BUTTON_STREAMS), fast_repeats)[0]]
    loop_s, slow = best_of(lambda: loop_segment(demo, THREE_BUTTON_STREAMS), loop_repeats)
    rows.append(_row("three-button (4 streams)", demo.n_steps, fast_s, loop_s, False,
                     fast.keypoints.tolist(), list(slow.keypoints)))

    # (b) one synthetic 3-D stream; the loop baseline measured at 10^4, extrapolated above
    per_sample_loop = None
    for n in (10_000, 100_000, 1_000_000):
        demo = synthetic_demo(n)
        repeats = fast_repeats if n < 1_000_000 else max(2, fast_repeats // 2)
        fast_s, fast = best_of(lambda d=demo: segment(d, window=SYNTHETIC_WINDOW, **PRODUCT), repeats)
        defaults_s.append(best_of(lambda d=demo: segment(d, window=SYNTHETIC_WINDOW), repeats)[0])
        estimate = None if per_sample_loop is None else per_sample_loop * n
        if estimate is None or (not quick and estimate < LOOP_BUDGET_S):
            reps = loop_repeats if n == 10_000 else 1
            loop_s, slow = best_of(lambda d=demo: loop_segment(d, window=SYNTHETIC_WINDOW), reps)
            per_sample_loop = per_sample_loop or loop_s / n
            rows.append(_row(f"synthetic 3-D, window {SYNTHETIC_WINDOW}", n, fast_s, loop_s, False,
                             fast.keypoints.tolist(), list(slow.keypoints)))
        else:
            rows.append(_row(f"synthetic 3-D, window {SYNTHETIC_WINDOW}", n, fast_s, estimate, True,
                             fast.keypoints.tolist(), None,
                             f"baseline = {per_sample_loop * 1e6:.2f} us/sample (measured at 10^4) x n"))
    for r in rows:
        if r["case"].startswith("synthetic") and not r["baseline_extrapolated"]:
            r["note"] = f"baseline measured: {r['baseline_s'] / r['n_samples'] * 1e6:.2f} us/sample"

    # (c) all five R demos, one after the other
    demos = read_handwriting_h5(root / "seed" / "r_shape.h5", group="normalized")
    total = sum(d.n_steps for d in demos)
    fast_s, fast = best_of(lambda: [segment(d, **PRODUCT) for d in demos], fast_repeats)
    defaults_s.append(best_of(lambda: [segment(d) for d in demos], fast_repeats)[0])
    loop_s, slow = best_of(lambda: [loop_segment(d) for d in demos], loop_repeats)
    rows.append(_row(f"R demos (all {len(demos)})", total, fast_s, loop_s, False,
                     [r.keypoints.tolist() for r in fast], [list(r.keypoints) for r in slow]))
    for r, d_s in zip(rows, defaults_s, strict=True):
        r["defaults_s"] = d_s

    synthetic = [r for r in rows if r["case"].startswith("synthetic")]
    growth = {r["n_samples"]: r["skillbank_s"] / r["n_samples"] * 1e6 for r in synthetic}
    machine = {"python": platform.python_version(), "numpy": np.__version__, "scipy": scipy.__version__,
               "cpus": os.cpu_count(), "platform": platform.platform(), "processor": platform.machine()}
    return {"rows": rows, "us_per_sample": growth, "machine": machine, "quick": quick}


def _fmt_s(seconds: float, extrapolated: bool) -> str:
    text = f"{seconds:.4f}" if seconds < 1 else f"{seconds:.2f}"
    return ("~" + text + " (extrapolated)") if extrapolated else text


def report(results: dict) -> str:
    m = results["machine"]
    lines = [f"Python {m['python']}, numpy {m['numpy']}, scipy {m['scipy']}, {m['cpus']} CPUs, "
             f"{m['platform']}", "",
             f"{'case':<30} {'n_samples':>10} {'skillbank s':>12} {'baseline s':>26} {'speed-up':>9} "
             f"{'defaults s':>11}"]
    for r in results["rows"]:
        ratio = ("~" if r["baseline_extrapolated"] else "") + f"{r['speedup']:.0f}x"
        lines.append(f"{r['case']:<30} {r['n_samples']:>10} {r['skillbank_s']:>12.4f} "
                     f"{_fmt_s(r['baseline_s'], r['baseline_extrapolated']):>26} {ratio:>9} "
                     f"{r.get('defaults_s', float('nan')):>11.4f}")
    lines.append("")
    growth = results["us_per_sample"]
    lines.append("linear growth, skillbank us/sample: " + ", ".join(
        f"10^{int(round(np.log10(n)))}: {v:.3f}" for n, v in growth.items()))
    for r in results["rows"]:
        if r["note"]:
            lines.append(f"n={r['n_samples']}: {r['note']}")
    for r in results["rows"]:
        if r["keypoints_baseline"] is not None and r["keypoints_baseline"] != r["keypoints_skillbank"]:
            lines.append(f"KEYPOINTS DIFFER for {r['case']}: skillbank {r['keypoints_skillbank']} "
                         f"baseline {r['keypoints_baseline']}")
    agree = all(r["keypoints_baseline"] == r["keypoints_skillbank"] for r in results["rows"]
                if r["keypoints_baseline"] is not None)
    lines.append("keypoints identical in every case where the baseline ran: " + ("yes" if agree else "NO"))
    return "\n".join(lines)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats; baseline only at 10^4 samples")
    parser.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    parser.add_argument("--roundoff", action="store_true",
                        help="also compare full precision with a 12-digit copy (10^4 to 10^6 samples)")
    parser.add_argument("--sweep", action="store_true",
                        help="only the agreement of full precision and copies, over many seeds (no timing)")
    parser.add_argument("--sweep-seeds", type=int, default=80, help="seeds of --sweep (default 80)")
    args = parser.parse_args(argv)
    if args.sweep:
        results = {"sweep": roundoff_sweep(args.sweep_seeds)}
        print(sweep_report(results["sweep"]))
        if args.json:
            Path(args.json).write_text(json.dumps(results, indent=2))
        return
    results = run(args.quick)
    print(report(results))
    if args.roundoff:
        results["roundoff"] = roundoff_rows()
        print(roundoff_report(results["roundoff"]))
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
