"""skillbank's segmentation against ruptures, the reference change-point library.

Run from the repository root (``make bench`` installs ruptures, the ``bench`` extra)::

    .venv/bin/python benchmarks/bench_ruptures.py [--json PATH] [--data DIR]

ruptures finds changes in a signal's distribution; a motion primitive boundary
is a change in how the demonstration moves, so ruptures is given each stream's
velocity (``np.gradient`` on the real time stamps), every column standardised,
streams side by side. It is run three ways:

- ``Pelt(l2)``: no number of cuts given; penalty ``3 log(n) d`` (a BIC-like
  choice for d standardised columns), minimum size = skillbank's minimum size;
- ``Pelt(rbf)``: the same with the kernel cost and penalty ``3 log(n)``;
- ``Dynp(l2), oracle k``: the exact optimum for the **true** number of cuts
  (an advantage skillbank does not get).

skillbank runs with its defaults. Cases with known boundaries: the five R
demonstrations (the corners: the two deepest interior speed minima), the
synthetic pick-and-place demonstration (boundaries at 400 and 800) and the
three-button demonstration (the paper reads 4 segments; issue 13 asks for a cut
within 0.5 s of each press, at about 9.2, 14.1 and 18.7 s, and allows cuts
within 1 s of the gripper closing and opening, at about 7.7 and 22.8 s, and no
other: "right count" means that criterion there; Dynp is given 4 segments as
the paper's count). Reported per case: whether the number of segments is right, the largest
distance from a true boundary to the nearest cut (samples), and the time (best
of 3). No timing is asserted anywhere.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
from pathlib import Path

import numpy as np

from skillbank.experiments import synthetic_multistream
from skillbank.io import read_handwriting_h5, read_robot_h5
from skillbank.segmentation import segment

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_of, data_dir  # noqa: E402

R_CORNERS = [(237, 680), (298, 764), (273, 708), (211, 629), (207, 684)]
THREE_BUTTON = ["joints", "position", "force", "gripper"]




def velocity_signal(demo, streams) -> np.ndarray:
    """The streams' velocities side by side, each column standardised (constant columns dropped)."""
    cols = [np.gradient(np.asarray(demo[s], dtype=float).reshape(demo.n_steps, -1), demo.t, axis=0)
            for s in streams]
    V = np.hstack(cols)
    sd = V.std(axis=0)
    V = V[:, sd > 0]
    return (V - V.mean(axis=0)) / V.std(axis=0)




def score(cuts, truth, n_segments_true) -> dict:
    cuts = np.asarray(cuts, dtype=int)
    err = max(int(np.abs(cuts - b).min()) if cuts.size else 10**9 for b in truth) if truth else 0
    return {"n_segments": int(cuts.size + 1), "count_ok": bool(cuts.size + 1 == n_segments_true),
            "max_error": err, "cuts": cuts.tolist()}


def methods(min_size: int, n_true_cuts: int, jump: int):
    import ruptures as rpt

    def pelt(cost, pen_per_dim):
        def run(V):
            pen = 3.0 * np.log(V.shape[0]) * (V.shape[1] if pen_per_dim else 1)
            return rpt.Pelt(model=cost, min_size=min_size, jump=jump).fit(V).predict(pen=pen)[:-1]
        return run

    def dynp(V):
        return rpt.Dynp(model="l2", min_size=min_size, jump=jump).fit(V).predict(n_bkps=n_true_cuts)[:-1]

    return {"ruptures Pelt(l2)": pelt("l2", True), "ruptures Pelt(rbf)": pelt("rbf", False),
            "ruptures Dynp(l2), oracle k": dynp}


PRESSES, GRIPPER = (9.2, 14.1, 18.7), (7.7, 22.8)


def three_button_ok(times) -> bool:
    """Issue 13's criterion: one cut near each press; any other cut near a gripper switch."""
    times = np.asarray(times, dtype=float)
    if times.size == 0:
        return False
    near_press = [np.abs(times - p).min() <= 0.5 for p in PRESSES]
    allowed = np.array(PRESSES + GRIPPER)
    tolerance = np.array([0.5] * len(PRESSES) + [1.0] * len(GRIPPER))
    return all(near_press) and all(np.any(np.abs(c - allowed) <= tolerance) for c in times)


def run_case(name, demo, streams, truth, n_segments_true) -> list:
    rows = []
    t_s, res = best_of(lambda: segment(demo, streams), 3)
    min_size = int(min(s.params["min_size"] for s in res.streams.values()))
    rows.append({"case": name, "method": "skillbank (defaults)", "time_s": t_s,
                 **score(res.keypoints, truth, n_segments_true)})
    V = velocity_signal(demo, streams if streams else demo.stream_names)
    # ruptures' own speed option: candidate cuts every ``jump`` samples (1 up to 1000 samples)
    jump = max(1, demo.n_steps // 1000)
    for label, fn in methods(min_size, n_segments_true - 1, jump).items():
        t_r, cuts = best_of(lambda f=fn: f(V), repeats=1 if "rbf" in label or "Dynp" in label else 3)
        rows.append({"case": name, "method": label, "time_s": t_r, **score(cuts, truth, n_segments_true)})
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=None, help="shared data folder (holds seed/)")
    parser.add_argument("--json", metavar="PATH", help="also write the rows as JSON")
    args = parser.parse_args(argv)
    import ruptures

    root = data_dir(args.data)
    rows = []
    for i, demo in enumerate(read_handwriting_h5(root / "seed" / "r_shape.h5", group="normalized")):
        rows += run_case(f"R demo {i}", demo, None, list(R_CORNERS[i]), 3)
    synth = synthetic_multistream()
    rows += run_case("synthetic pick-and-place", synth, None, synth.metadata["true_keypoints"], 3)
    buttons = read_robot_h5(root / "seed" / "three_button_pressing_demo.h5")
    rows += run_case("three-button", buttons, THREE_BUTTON, [], 4)
    for r in rows:
        if r["case"] == "three-button":
            r["count_ok"] = three_button_ok(buttons.t[r["cuts"]] - buttons.t[0])

    print(f"Python {platform.python_version()}, numpy {np.__version__}, ruptures {ruptures.__version__}, "
          f"{os.cpu_count()} CPUs\n")
    print("| case | method | segments | right count | max error (samples) | time (ms) |")
    print("| --- | --- | ---: | :---: | ---: | ---: |")
    for r in rows:
        err = "-" if r["case"] == "three-button" else (r["max_error"] if r["max_error"] < 10**9 else "none")
        print(f"| {r['case']} | {r['method']} | {r['n_segments']} | {'yes' if r['count_ok'] else 'no'} | "
              f"{err} | {r['time_s'] * 1e3:.1f} |")
    print()
    for m in dict.fromkeys(r["method"] for r in rows):
        mine = [r for r in rows if r["method"] == m]
        ok = sum(r["count_ok"] for r in mine)
        exact = sum(r["count_ok"] and r["max_error"] <= 30 for r in mine if r["case"] != "three-button")
        print(f"{m}: right number of segments in {ok}/{len(mine)} cases; right count and every "
              f"boundary within 30 samples in {exact}/{len(mine) - 1} cases with known boundaries; "
              f"total {sum(r['time_s'] for r in mine) * 1e3:.0f} ms")
    buttons_rows = [r for r in rows if r["case"] == "three-button"]
    for r in buttons_rows:
        print(f"three-button, {r['method']}: cuts at {np.round(buttons.t[r['cuts']], 2).tolist()} s")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
