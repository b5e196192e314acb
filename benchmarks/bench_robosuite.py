"""Task success on robosuite's tasks: skillbank's adapted skills against MimicGen-style baselines.

For each task, the path a user runs, through the command line:

1. ``skillbank sim record robosuite:TASK --episodes 10 --seed RECORD_SEED`` (the source demonstrations);
2. ``skillbank library init`` and ``library add --assign recluster`` (segment, cluster);
3. ``skillbank sim evaluate LIB --env robosuite:TASK --episodes N --seed EVAL_SEED [--placement 0.15]
   --method M --json`` for every method on the same episodes (same seeds, same scenes):

- ``lte`` (skillbank's default): each segment adapted by Laplacian trajectory editing from where the
  robot is to the goal the scene gives;
- ``dmp``: a DMP learned from the one source segment, reproduced to the same start and goal;
- ``rigid`` (MimicGen's transform): the source segment moved rigidly into its frame's new pose,
  ``T_new · T_source⁻¹ · T_tool(t)``, after a 5-step interpolation from the current pose;
- ``replay``: the nearest source demonstration's actions, open loop.

The evaluation seeds are never the recording's, and every rate comes with its Wilson 95 % interval.
``--figure FILE`` draws one episode of the first task at the wide placement (the first from ``--seed``
in which the two differ, if one of ten does): the source demonstrations' tool paths, the new
placement, the adapted path and the rigid baseline's, and whether each succeeded.

    python benchmarks/bench_robosuite.py --episodes 20 --seed 1000 --figure docs/figures/robosuite.png
    python benchmarks/bench_robosuite.py --tasks Stack --figure-only --seed 5000 \
        --figure docs/figures/robosuite_stack.png   # the README's figure (record, build, draw: ~3 min)
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import robosuite_library, skillbank  # noqa: E402

TASKS = ["Lift", "Stack", "PickPlaceCan", "NutAssemblySquare"]
METHODS = ["lte", "dmp", "rigid", "replay"]




def evaluate(db: Path, task: str, method: str, episodes: int, seed: int, placement) -> dict:
    args = ["sim", "evaluate", db, "--env", f"robosuite:{task}", "--episodes", episodes, "--seed", seed,
            "--method", method, "--json"]
    if placement is not None:
        args += ["--placement", placement]
    tic = time.perf_counter()
    report = json.loads(skillbank(*args))
    report["wall_seconds"] = time.perf_counter() - tic
    return report


def figure(db: Path, task: str, seed: int, placement: float, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from skillbank.simulation import evaluate as run
    from skillbank.store import open_store

    with open_store(db, create=False, readonly=True) as store:
        demos = store.demonstrations(store.demonstration_ids())
    # the first episode from ``seed`` in which the two methods differ (else the first): the figure shows
    # what the rates count
    for shown in range(seed, seed + 10):
        runs = {m: run(db, f"robosuite:{task}", episodes=1, seed=shown, placement=placement, method=m,
                       paths=True)["per_episode"][0] for m in ("lte", "rigid")}
        if runs["lte"]["success"] != runs["rigid"]["success"]:
            break
    else:
        shown = seed
        runs = {m: run(db, f"robosuite:{task}", episodes=1, seed=shown, placement=placement, method=m,
                       paths=True)["per_episode"][0] for m in ("lte", "rigid")}
    fig = Figure(figsize=(11, 5.4), layout="constrained")
    views = [(0, 1, "x (m)", "y (m)", "seen from above"), (0, 2, "x (m)", "z (m)", "seen from the side")]
    for k, (i, j, xl, yl, title) in enumerate(views):
        ax = fig.add_subplot(1, 2, k + 1)
        for n, d in enumerate(demos.values()):
            ax.plot(d["position"][:, i], d["position"][:, j], color="0.75", lw=0.8,
                    label="source demonstrations" if n == 0 else None)
        for n, d in enumerate(demos.values()):
            names = [s[:-4] for s in d.stream_names if s.endswith("_pos") and f"{s[:-4]}_quat" in d.streams]
            for m, name in enumerate(names):
                ax.plot(d[f"{name}_pos"][0, i], d[f"{name}_pos"][0, j], "s", color="0.6", ms=4,
                        label="objects in the demonstrations" if n == m == 0 else None)
        styles = {"lte": ("tab:blue", "skillbank (LTE)"),
                  "rigid": ("tab:orange", "rigid transform (MimicGen)")}
        for method, row in runs.items():
            path = row["path"]
            colour, name = styles[method]
            said = "succeeded" if row["success"] else f"failed, {row['failure']['reason']}"
            ax.plot([p[i] for p in path], [p[j] for p in path], color=colour, lw=1.8, label=f"{name}: {said}")
        # each object's new placement with a marker of its own and its name (two red stars were two
        # objects nobody could tell apart)
        for m, (name, where) in enumerate(sorted(runs["lte"]["objects"].items())):
            ax.plot(where[i], where[j], "*^Ds"[m % 4], color=("tab:red", "tab:purple", "tab:brown")[m % 3],
                    ms=12 if m == 0 else 8, ls="none", label=f"new placement of {name}")
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        ax.set_title(title)
        if i == 0 and j == 1:
            ax.set_aspect("equal", adjustable="datalim")
    # below both panels: inside one, "best" still covered paths (both panels are full of them)
    fig.legend(*fig.axes[0].get_legend_handles_labels(), loc="outside lower center", ncols=3, fontsize=8)
    fig.suptitle(f"robosuite {task}, UR5e: episode seed {shown}, placement ±{placement} m")
    fig.savefig(out, dpi=110)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--tasks", nargs="+", default=TASKS)
    p.add_argument("--methods", nargs="+", default=METHODS)
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--demos", type=int, default=10)
    p.add_argument("--record-seed", type=int, default=0)
    p.add_argument("--seed", type=int, default=1000, help="the first evaluation seed")
    p.add_argument("--wide", type=float, default=0.15, help="half-width of the wide placement (m)")
    p.add_argument("--figure", type=Path, default=None)
    p.add_argument("--figure-only", action="store_true", help="record, build and draw; no rates")
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for task in args.tasks:
            db = robosuite_library(Path(tmp), task, args.record_seed, args.demos)
            for placement in () if args.figure_only else (None, args.wide):
                for method in args.methods:
                    r = evaluate(db, task, method, args.episodes, args.seed, placement)
                    reasons = {}
                    for e in r["per_episode"]:
                        if not e["success"]:
                            reasons[e["failure"]["reason"]] = reasons.get(e["failure"]["reason"], 0) + 1
                    t = r["timing"]
                    rows.append({"task": task, "placement": placement, "method": method,
                                 "successes": r["successes"], "episodes": r["episodes"],
                                 "rate": r["success_rate"], "wilson95": r["interval"], "failures": reasons,
                                 "adapt_ms_per_segment": 1e3 * t["adapt_seconds"] / max(t["segments"], 1),
                                 "driven_s_per_segment": t["driven_seconds"] / max(t["segments"], 1),
                                 "wall_seconds": r["wall_seconds"]})
                    if not args.json:
                        lo, hi = r["interval"]
                        print(f"{task:18s} {'default' if placement is None else f'+-{placement} m':9s} "
                              f"{method:7s} {r['successes']:3d}/{r['episodes']:<3d} "
                              f"{100 * r['success_rate']:5.1f} % [{100 * lo:4.1f}, {100 * hi:5.1f}]  "
                              f"adapt {rows[-1]['adapt_ms_per_segment']:.1f} ms/segment for "
                              f"{rows[-1]['driven_s_per_segment']:.2f} s driven  {reasons}", flush=True)
            if args.figure is not None and task == args.tasks[0]:
                figure(db, task, args.seed, args.wide, args.figure)
    if args.json:
        print(json.dumps(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
