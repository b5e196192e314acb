"""Segmentation quality: F1 of the boundaries on stitched sequences of real primitives.

Run from the repository root (``make bench`` installs ruptures, the ``bench`` extra)::

    .venv/bin/python benchmarks/bench_segmentation_quality.py [--quick] [--seeds 0 1 2 3 4]
        [--n 48] [--jitter 0] [--rates 100 300 500] [--by-rate] [--no-ruptures] [--json PATH]
        [--data DIR] [--primitives LO HI] [--old-window]

The sequences come from ``benchmarks/_stitched.py`` (its docstring describes the generator):
2 to 5 real primitives (RAIL, LASA, three-button pieces), each brought smoothly to rest, dwells of
0 to 40/300 s, at 100, 300 and 500 Hz, with 0, 10 and 20 µm of position noise, with and without a
gripper and a force stream. Each seed gives ``--n`` sequences with every condition's levels
balanced over them. ``--rates`` samples at other rates (balanced over the sequences like the
default three); ``--by-rate`` instead builds one suite per rate, the same motions at each, and
prints skillbank's defaults per rate and noise level (how the defaults hold at 1-2 kHz).
``--primitives 20 49`` chains 20 to 49 primitives per sequence instead (recordings of minutes, as
a lab records), and ``--old-window`` adds skillbank with the former default window, 4 % of the
recording, beside the defaults.

Score of one sequence (:func:`score`): predicted and true boundary times are matched one to one
(Hungarian assignment: the most matches within ``tol`` = 0.1 s, then the smallest total error);
precision = matches / predictions, recall = matches / truths, F1 their harmonic mean. With no
prediction, precision is 1 (nothing claimed wrongly), so F1 is 0 unless the truth is empty too
(then F1 = 1; the generator never makes such a sequence). The table gives the mean of the
per-sequence F1 and the mean absolute error of all matched boundaries (ms).

Methods, all in this process on the same sequences:

- ``skillbank (defaults)``: ``segment(demo)``: rests, turns, contact steps and impacts, gripper
  switches, combined by kind with noisy-OR (``combine="evidence"``);
- ``skillbank (stops only)``: the same with ``min_turn=None`` (no boundary at a turn without a
  stop);
- ``skillbank (product rule)``: ``segment(demo, combine="product")``, the paper's combination with
  skillbank's other defaults;
- ``skillbank (paper)``: ``segment(demo, combine="product", stop_ratio=None, normalize="max",
  scale="absolute")``;
- ``zero-velocity``: local minima of the speed (position stream, Gaussian-smoothed over 0.03 s)
  with a prominence of at least a fraction of the largest speed and at least 0.2 s apart; the
  fraction is the best of several **in hindsight** (over all the sequences of the run);
- ``ruptures KernelCPD(rbf)`` and ``ruptures Pelt(l2)`` on all the streams side by side, either
  their velocities or their values (each column standardised, constant ones dropped), subsampled
  to about ``RUPTURES_RATE`` Hz, minimum segment 0.2 s; the signal and the penalty are the best
  of several in hindsight (see :func:`ruptures_method`).

Hindsight choices make the baselines stronger than they would be in use; skillbank gets none.

Use from Python to tune a segmenter::

    import sys; sys.path.insert(0, "benchmarks")
    from bench_segmentation_quality import build_suite, evaluate, skillbank_method
    suite = build_suite(seeds=[0, 1, 2], n=48)
    report = evaluate(lambda demo: my_segment(demo).keypoint_times, suite)
    report["mean_f1"], report["seed_f1"], report["by_condition"]["family"]
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _stitched import make_suite  # noqa: E402

from skillbank.segmentation import segment  # noqa: E402

__all__ = ["score", "evaluate", "evaluate_best", "build_suite", "skillbank_method", "zero_velocity",
           "ruptures_method", "run", "TOL"]

TOL = 0.1
ZERO_VELOCITY_PROMINENCES = (0.05, 0.1, 0.2, 0.3, 0.4, 0.5)
#: penalties as multiples of log(n) (KernelCPD: its cost per sample is at most 1) ...
KERNEL_PENALTIES = (1.0, 2.0, 5.0, 10.0, 20.0)
#: ... and of log(n) * d for Pelt(l2) on d unit-variance columns
PELT_PENALTIES = (2.0, 5.0, 10.0, 20.0, 50.0)
RUPTURES_RATE = 50.0
FACTORS = ("noise", "rate", "gripper", "force", "family")
#: ``--by-rate`` without ``--rates``: the benchmark's rates, then a Franka's 1 kHz and twice that
BY_RATE_RATES = (100.0, 300.0, 500.0, 1000.0, 2000.0)


# ----------------------------------------------------------------------------------------- scoring
def score(pred_times, truth_times, tol=TOL):
    """``(precision, recall, f1, mean_abs_error)`` of predicted against true boundary times.

    One-to-one matching within ``tol`` seconds, as many matches as possible, then the smallest total
    error. ``mean_abs_error`` is over the matches (NaN without any). No prediction: precision 1;
    no truth: recall 1; both empty: F1 = 1.

    >>> score([1.0, 2.05], [1.0, 2.0])[2]
    1.0
    >>> score([1.0], [1.0, 2.0])[:3]
    (1.0, 0.5, 0.6666666666666666)
    """
    errors = match_errors(pred_times, truth_times, tol)
    n_pred, n_truth = np.size(pred_times), np.size(truth_times)
    m = errors.size
    precision = m / n_pred if n_pred else 1.0
    recall = m / n_truth if n_truth else 1.0
    f1 = 0.0 if precision + recall == 0 else 2 * precision * recall / (precision + recall)
    return precision, recall, f1, float(errors.mean()) if m else float("nan")


def match_errors(pred_times, truth_times, tol=TOL) -> np.ndarray:
    """Absolute errors of the one-to-one matches within ``tol`` (see :func:`score`)."""
    from scipy.optimize import linear_sum_assignment

    p = np.asarray(pred_times, dtype=float).ravel()
    q = np.asarray(truth_times, dtype=float).ravel()
    if p.size == 0 or q.size == 0:
        return np.zeros(0)
    d = np.abs(p[:, None] - q[None, :])
    # an out-of-tolerance pair costs more than all in-tolerance pairs together: the assignment
    # first maximises the number of matches, then minimises their total error
    big = tol * (min(p.size, q.size) + 1)
    rows, cols = linear_sum_assignment(np.where(d <= tol, d, big))
    e = d[rows, cols]
    return e[e <= tol]


# ----------------------------------------------------------------------------------------- methods
def skillbank_method(**params):
    """A method: ``segment(demo, **params).keypoint_times``."""
    def run_(demo):
        return segment(demo, **params).keypoint_times
    return run_


def zero_velocity(prominence, smooth=0.03, min_gap=0.2):
    """A method: local minima of the smoothed speed of ``position``, prominence relative to its max."""
    from scipy.ndimage import gaussian_filter1d
    from scipy.signal import find_peaks

    def run_(demo):
        t = demo.t
        dt = float(np.median(np.diff(t)))
        v = np.linalg.norm(np.gradient(np.asarray(demo["position"], float), t, axis=0), axis=1)
        v = gaussian_filter1d(v, max(smooth / dt, 0.5))
        peaks, _ = find_peaks(-v, prominence=prominence * v.max(), distance=max(1, int(min_gap / dt)))
        return t[peaks]
    return run_


def _signal(demo, step, kind):
    """The streams (``kind="position"``: as recorded; ``"velocity"``: their time derivatives) side
    by side, subsampled by ``step``, every column standardised (constant columns dropped)."""
    cols = []
    for s in demo.stream_names:
        x = np.asarray(demo[s], float).reshape(demo.n_steps, -1)
        cols.append(np.gradient(x, demo.t, axis=0) if kind == "velocity" else x)
    V = np.hstack(cols)[::step]
    sd = V.std(axis=0)
    V = V[:, sd > 1e-12]
    return (V - V.mean(axis=0)) / V.std(axis=0)


def ruptures_method(kind, penalties, signals=("velocity", "position")):
    """A method returning, for each ``(signal, penalty)``, the boundary times.

    ``kind`` is ``"kernel"`` (``KernelCPD(kernel="rbf")``, penalty ``c log n``) or ``"pelt"``
    (Pelt with the l2 cost, penalty ``c d log n`` for d columns). Pelt(l2) runs as
    ``KernelCPD(kernel="linear")``: ruptures' compiled Pelt with the same cost (the linear
    kernel's cost is the l2 cost); ``rpt.Pelt(model="l2")``, pure Python, took 3 to 20 s per
    sequence, and gave identical cuts on all 18 (sequence, penalty) pairs checked. The fit is
    shared by the penalties; a cut at subsampled index ``i`` maps to the time halfway between
    subsampled samples ``i - 1`` and ``i``.
    """
    import ruptures as rpt

    def run_(demo):
        step = max(1, int(round(1.0 / (float(np.median(np.diff(demo.t))) * RUPTURES_RATE))))
        ts = demo.t[::step]
        min_size = max(2, int(round(0.2 * RUPTURES_RATE)))
        out = {}
        for signal in signals:
            V = _signal(demo, step, signal)
            n = V.shape[0]
            algo = rpt.KernelCPD(kernel="rbf" if kind == "kernel" else "linear", min_size=min_size).fit(V)
            for c in penalties:
                pen = c * np.log(n) * (1 if kind == "kernel" else V.shape[1])
                cuts = np.asarray(algo.predict(pen=pen)[:-1], dtype=int)
                out[(signal, c)] = 0.5 * (ts[cuts - 1] + ts[cuts]) if cuts.size else np.zeros(0)
        return out
    return run_


# -------------------------------------------------------------------------------------- evaluation
def build_suite(seeds=(0, 1, 2, 3, 4), n=48, data=None, jitter=0.0, rates=None, primitives=None):
    """The cases of every seed, in order (``_stitched.make_suite(seed, n)`` for each seed).

    ``rates``: the sampling rates (Hz) balanced over each seed's sequences; default
    ``_stitched.RATES`` (100, 300, 500).
    """
    return [case for s in seeds
            for case in make_suite(int(s), int(n), data=data, jitter=jitter, rates=rates,
                                   primitives=primitives)]


def _summarise(rows) -> dict:
    f1 = np.array([r["f1"] for r in rows])
    errs = np.concatenate([r["errors"] for r in rows]) if rows else np.zeros(0)
    out = {"mean_f1": float(f1.mean()), "precision": float(np.mean([r["precision"] for r in rows])),
           "recall": float(np.mean([r["recall"] for r in rows])),
           "mean_error": float(errs.mean()) if errs.size else float("nan"), "n_sequences": len(rows)}
    seeds = sorted({r["seed"] for r in rows})
    per_seed = {s: float(np.mean([r["f1"] for r in rows if r["seed"] == s])) for s in seeds}
    out["seed_f1"] = per_seed
    vals = np.array(list(per_seed.values()))
    out["seed_spread"] = {"mean": float(vals.mean()), "min": float(vals.min()), "max": float(vals.max()),
                          "std": float(vals.std())}
    by = {}
    for factor in FACTORS:
        levels = sorted({_level(r["conditions"][factor]) for r in rows}, key=str)
        by[factor] = {lv: float(np.mean([r["f1"] for r in rows if _level(r["conditions"][factor]) == lv]))
                      for lv in levels}
    out["by_condition"] = by
    out["rows"] = rows
    return out


def _level(value):
    """A condition level as a table label: noise in µm, rate in Hz, booleans as on/off."""
    if isinstance(value, (bool, np.bool_)):
        return "on" if value else "off"
    if isinstance(value, float) and value < 1e-3:
        return f"{value * 1e6:g} µm"
    if isinstance(value, float):
        return f"{value:g} Hz"
    return str(value)


def _row(case, pred, tol, seconds):
    pred = np.sort(np.asarray(pred, dtype=float).ravel())
    p, r, f1, _ = score(pred, case.truth, tol)
    return {"seed": case.seed, "index": case.index, "conditions": case.conditions, "precision": p,
            "recall": r, "f1": f1, "errors": match_errors(pred, case.truth, tol), "n_pred": int(pred.size),
            "n_truth": int(case.truth.size), "pred": pred.tolist(), "seconds": seconds}


def evaluate(method, suite, tol=TOL) -> dict:
    """Score ``method`` (``demo -> boundary times in seconds``) on every case of ``suite``.

    Returns a dict: ``mean_f1`` (mean of the per-sequence F1), ``precision``, ``recall``,
    ``mean_error`` (s, over all matches), ``seed_f1`` (mean F1 per seed), ``seed_spread``
    (mean/min/max/std of those), ``by_condition`` (factor -> level -> mean F1), ``rows``
    (one dict per sequence, with its predictions), ``seconds`` (total time of the method).
    """
    rows = []
    for case in suite:
        start = time.perf_counter()
        pred = method(case.demo)
        rows.append(_row(case, pred, tol, time.perf_counter() - start))
    out = _summarise(rows)
    out["seconds"] = float(sum(r["seconds"] for r in rows))
    return out


def evaluate_best(multi_method, suite, tol=TOL):
    """For a method giving ``{parameter: times}`` per demo: the best parameter in hindsight.

    Returns ``(best_parameter, report_of_best, {parameter: mean_f1})``.
    """
    rows = {}
    seconds = 0.0
    for case in suite:
        start = time.perf_counter()
        preds = multi_method(case.demo)
        seconds += time.perf_counter() - start
        for param, pred in preds.items():
            rows.setdefault(param, []).append(_row(case, pred, tol, 0.0))
    reports = {param: _summarise(r) for param, r in rows.items()}
    best = max(reports, key=lambda k: reports[k]["mean_f1"])
    reports[best]["seconds"] = seconds
    return best, reports[best], {k: v["mean_f1"] for k, v in reports.items()}


def by_rate(seeds, n, rates=BY_RATE_RATES, *, method=None, data=None, jitter=0.0) -> dict:
    """``{rate: report}``: ``method`` (default skillbank's defaults) on one suite per rate.

    Each suite holds the same motions (see ``_stitched.make_suite``), all sampled at that rate.
    """
    method = skillbank_method() if method is None else method
    return {float(r): evaluate(method, build_suite(seeds, n, data=data, jitter=jitter, rates=(float(r),)))
            for r in rates}


def _grid(methods):
    """``{parameter: method}`` as one multi-method."""
    return lambda demo: {param: m(demo) for param, m in methods.items()}


def fraction_window(demo):
    """The default window before issue 27: 4 % of the recording (at least 8 samples), whatever its motion."""
    return segment(demo, window=max(8, round(0.04 * demo.n_steps))).keypoint_times


def run(suite, *, ruptures=True, tol=TOL, old_window=False) -> dict:
    """Every method on ``suite``: ``{label: report}`` (hindsight picks in ``report["choice"]``).

    ``old_window``: also skillbank with the window the default used to be (:func:`fraction_window`).
    """
    reports = {}
    reports["skillbank (defaults)"] = evaluate(skillbank_method(), suite, tol)
    if old_window:
        reports["skillbank (window 4 % of the recording)"] = evaluate(fraction_window, suite, tol)
    reports["skillbank (stops only)"] = evaluate(skillbank_method(min_turn=None), suite, tol)
    reports["skillbank (product rule)"] = evaluate(skillbank_method(combine="product"), suite, tol)
    reports["skillbank (paper)"] = evaluate(
        skillbank_method(combine="product", stop_ratio=None, normalize="max", scale="absolute"), suite, tol)
    zero = _grid({p: zero_velocity(p) for p in ZERO_VELOCITY_PROMINENCES})
    best, rep, grid = evaluate_best(zero, suite, tol)
    rep["choice"] = {"prominence": best, "grid": grid}
    reports["zero-velocity (best prominence)"] = rep
    if ruptures:
        for label, kind, pens in (("ruptures KernelCPD(rbf) (best penalty)", "kernel", KERNEL_PENALTIES),
                                  ("ruptures Pelt(l2) (best penalty)", "pelt", PELT_PENALTIES)):
            best, rep, grid = evaluate_best(ruptures_method(kind, pens), suite, tol)
            rep["choice"] = {"signal/penalty": best, "grid": grid}
            reports[label] = rep
    return reports


# ------------------------------------------------------------------------------------------ output
def table(reports) -> str:
    """The Markdown table: one column per method, overall rows then one row per condition level."""
    names = list(reports)
    short = [n.replace(" (best prominence)", "*").replace(" (best penalty)", "*") for n in names]
    lines = ["| | " + " | ".join(short) + " |", "| --- |" + " ---: |" * len(names)]

    def line(label, values):
        lines.append(f"| {label} | " + " | ".join(values) + " |")

    line("**mean F1**", [f"**{reports[n]['mean_f1']:.3f}**" for n in names])
    line("per-seed mean F1: min–max", [f"{reports[n]['seed_spread']['min']:.3f}–"
                                       f"{reports[n]['seed_spread']['max']:.3f}" for n in names])
    line("precision / recall", [f"{reports[n]['precision']:.2f} / {reports[n]['recall']:.2f}" for n in names])
    line("mean boundary error (ms)", [f"{1000 * reports[n]['mean_error']:.0f}" for n in names])
    line("time (s, all sequences)", [f"{reports[n]['seconds']:.1f}" for n in names])
    first = reports[names[0]]
    for factor in FACTORS:
        for level in first["by_condition"][factor]:
            line(f"{factor} = {level}", [f"{reports[n]['by_condition'][factor][level]:.3f}" for n in names])
    return "\n".join(lines)


def rate_table(reports) -> str:
    """The Markdown table of :func:`by_rate`: one row per rate."""
    first = next(iter(reports.values()))["by_condition"]
    noise, family = list(first["noise"]), list(first["family"])
    head = ["rate", "mean F1", "per-seed min–max", "precision / recall", "error (ms)"] + \
        [f"noise {lv}" for lv in noise] + family + ["time (s)"]
    lines = ["| " + " | ".join(head) + " |", "| --- |" + " ---: |" * (len(head) - 1)]
    for rate, rep in reports.items():
        cells = [f"{rate:g} Hz", f"**{rep['mean_f1']:.3f}**",
                 f"{rep['seed_spread']['min']:.3f}–{rep['seed_spread']['max']:.3f}",
                 f"{rep['precision']:.2f} / {rep['recall']:.2f}", f"{1000 * rep['mean_error']:.0f}"]
        cells += [f"{rep['by_condition']['noise'][lv]:.3f}" for lv in noise]
        cells += [f"{rep['by_condition']['family'][lv]:.3f}" for lv in family]
        lines.append("| " + " | ".join(cells + [f"{rep['seconds']:.1f}"]) + " |")
    return "\n".join(lines)


def _param(key):
    return "/".join(f"{k:g}" if isinstance(k, float) else str(k) for k in key) if isinstance(key, tuple) \
        else f"{key:g}"


def _jsonable(reports):
    out = {}
    for name, rep in reports.items():
        r = {k: v for k, v in rep.items() if k != "rows"}
        r["seed_f1"] = {str(k): v for k, v in r["seed_f1"].items()}
        if "choice" in r:
            r["choice"] = {"value": _param(next(v for k, v in r["choice"].items() if k != "grid")),
                           "grid": {_param(k): v for k, v in r["choice"]["grid"].items()}}
        r["sequences"] = [{**{k: v for k, v in row.items() if k != "errors"},
                           "conditions": {k: _level(v) for k, v in row["conditions"].items()},
                           "errors": row["errors"].tolist()} for row in rep["rows"]]
        out[name] = r
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 seeds x 24 sequences (under a minute)")
    parser.add_argument("--seeds", type=int, nargs="+", default=None, help="seeds (default 0 1 2 3 4)")
    parser.add_argument("--n", type=int, default=None, help="sequences per seed (default 48)")
    parser.add_argument("--jitter", type=float, default=0.0,
                        help="uneven clock: each stamp moved by up to jitter/2 of a period (default 0)")
    parser.add_argument("--rates", type=float, nargs="+", default=None,
                        help="sampling rates in Hz (default 100 300 500; with --by-rate also 1000 2000)")
    parser.add_argument("--by-rate", action="store_true",
                        help="skillbank's defaults on one suite per rate (the same motions at each)")
    parser.add_argument("--no-ruptures", action="store_true", help="skip the ruptures baselines")
    parser.add_argument("--primitives", type=int, nargs=2, metavar=("LO", "HI"), default=None,
                        help="primitives per sequence (default 2 5); e.g. 20 49 for long recordings")
    parser.add_argument("--old-window", action="store_true",
                        help="also skillbank with the former default window, 4 %% of the recording")
    parser.add_argument("--data", default=None, help="shared data folder (holds seed/ and rail/)")
    parser.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    args = parser.parse_args(argv)
    seeds = args.seeds or ([0, 1] if args.quick else [0, 1, 2, 3, 4])
    n = args.n or (24 if args.quick else 48)

    if args.rates is not None and (not args.rates or min(args.rates) <= 0):
        raise SystemExit(f"--rates: expected rates > 0 in Hz, got {args.rates}")
    if args.by_rate:
        rates = tuple(args.rates or BY_RATE_RATES)
        reports = by_rate(seeds, n, rates, data=args.data, jitter=args.jitter)
        print(f"skillbank (defaults), seeds {seeds}, {n} sequences per seed and rate, jitter "
              f"{args.jitter:g}; tol ±{TOL} s\n")
        print(rate_table(reports))
        if args.json:
            Path(args.json).write_text(json.dumps({"seeds": seeds, "n": n, "tol": TOL, "by_rate": _jsonable(
                {f"{r:g} Hz": rep for r, rep in reports.items()})}, indent=1))
        return
    start = time.perf_counter()
    if args.primitives is not None and not 1 <= args.primitives[0] <= args.primitives[1]:
        raise SystemExit(f"--primitives: expected 1 <= LO <= HI, got {args.primitives}")
    suite = build_suite(seeds, n, data=args.data, jitter=args.jitter, rates=args.rates,
                        primitives=args.primitives)
    gen = time.perf_counter() - start
    reports = run(suite, ruptures=not args.no_ruptures, old_window=args.old_window)

    import scipy
    versions = f"Python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}"
    if not args.no_ruptures:
        import ruptures
        versions += f", ruptures {ruptures.__version__}"
    print(f"{versions}\nseeds {seeds}, {n} sequences per seed ({len(suite)} in all, "
          f"{sum(c.truth.size for c in suite)} boundaries), jitter {args.jitter:g}, "
          f"generated in {gen:.1f} s; tol ±{TOL} s\n")
    print(table(reports))
    print("\n* parameter picked in hindsight:")
    for name, rep in reports.items():
        if "choice" in rep:
            grid = ", ".join(f"{_param(k)}: {v:.3f}" for k, v in rep["choice"]["grid"].items())
            print(f"  {name}: mean F1 by parameter {{{grid}}}")
    if args.json:
        Path(args.json).write_text(json.dumps({"seeds": seeds, "n": n, "tol": TOL,
                                               "methods": _jsonable(reports)}, indent=1))


if __name__ == "__main__":
    main()
