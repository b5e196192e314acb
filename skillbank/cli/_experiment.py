"""``skillbank experiment``: ``rail``, the paper's RAIL clustering experiment (Fig. 4); ``unload`` and
``stack3``, beyond the paper: a task composed from single demonstrations, planned and executed in robosuite
(what the paper leaves to future work). ``unload`` and ``stack3`` exit 0 when they ran, whatever the success
rate; with ``--out DIR`` they keep what they recorded and built there."""

from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

from ._options import (
    EPISODES_DEFAULT,
    add_episode_options,
    check_folder,
    parallel_params,
    show_progress,
    verbose_logging,
)
from ._output import add_force_option

__all__ = ["add_parser", "run"]


def add_parser(sub):
    """Register ``experiment`` (with its ``rail`` sub-command) on argparse subparsers ``sub``.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="skillbank")
    >>> add_parser(parser.add_subparsers(dest="command"))  # doctest: +ELLIPSIS
    ArgumentParser(...)
    """
    p = sub.add_parser("experiment", help="run a reproducible experiment: rail, the paper's clustering "
                                          "experiment; unload and stack3, tasks composed in physics (beyond "
                                          "the paper)")
    experiments = p.add_subparsers(dest="experiment", required=True)
    rail = experiments.add_parser(
        "rail", help="the paper's experiment: cluster RAIL demonstrations with elastic and agglomerative "
                     "clustering (Fig. 4)")
    rail.add_argument("--data", type=Path, required=True,
                      help="the RAIL folder (REACHING/, PUSHING/, ...) or a folder holding rail/")
    rail.add_argument("--mode", choices=["default", "paper"], default="default",
                      help="paper: the paper's representatives and settings; default: no labels at all")
    rail.add_argument("--classes", default="reaching,pushing,writing",
                      help="comma-separated classes among reaching, pushing, pressing, writing")
    rail.add_argument("--seed", type=int, default=0, help="random seed (first elastic node, PCA)")
    rail.add_argument("--json", action="store_true", help="print the result as JSON")
    rail.add_argument("--plot", type=Path, default=None,
                      help="write the cluster comparison figure to this file (.png, .pdf, .svg; no "
                           "extension: .png)")
    rail.set_defaults(func=run)
    for name, text in (("unload", "record one object at a time in robosuite's PickPlace, learn pick and "
                                  "place, and plan and execute unloading all four objects"),
                       ("stack3", "record robosuite's Stack (one cube on another), learn pick and place, and "
                                  "plan and execute stacking three cubes in an order drawn per episode")):
        c = experiments.add_parser(name, help=text + " (not in the paper, which leaves it to future work; "
                                                    "needs skillbank[sim])")
        c.add_argument("--episodes", type=int, default=EPISODES_DEFAULT,
                       help=f"scenes (default {EPISODES_DEFAULT}, as 'sim evaluate')")
        c.add_argument("--seed", type=int, default=0,
                       help="seeds the recordings (SEED, SEED + 1, ...) and the scenes (episode k from "
                            "SEED + 1000 + k); default 0")
        c.add_argument("--demos", type=int, default=10, help="demonstrations per recorded task (default 10)")
        c.add_argument("--method", default="lte",
                       help="lte (default) or another method; replay: the phases' recorded actions in the "
                            "planned order (the baseline)")
        c.add_argument("--planner", choices=["ompl", "none"], default="ompl",
                       help="free-space moves (the transit to a reach's start, the far part of a reach or a "
                            "carry, a retreat after a release) followed for the whole arm in the scene's "
                            "MuJoCo geometry and, where a link, the gripper or a held object would come near "
                            "it, planned in joint space by OMPL's RRTConnect ('ompl', default; "
                            "skillbank[plan]); 'none' drives them as adapted, as 'sim evaluate --planner'")
        c.add_argument("--replan", action="store_true", help="plan again from the observed facts when a "
                                                             "step's effect did not happen")
        c.add_argument("--robot", default="UR5e", metavar="ARM",
                       help="robosuite's arm that carries the plans out, with its default gripper: UR5e "
                            "(default), Panda, Sawyer, IIWA, Jaco, Kinova3, XArm7 (any case), as 'sim "
                            "evaluate --robot'")
        c.add_argument("--record-robot", default="UR5e", metavar="ARM",
                       help="robosuite's arm the demonstrations are recorded on, as 'sim record --robot' "
                            "(default UR5e, any case); another than --robot runs the skills on an arm that "
                            "did not show them, through the grip site's pose (a note says so)")
        c.add_argument("--out", type=Path, default=None, metavar="DIR",
                       help=f"keep what the experiment recorded and built in DIR (new or empty, else "
                            f"--force): the demonstrations (TASK.hdf5, for 'library add'), the labelled "
                            f"and described library ({name}.db, for 'plan', 'sim evaluate', 'library "
                            f"view'), the first episode's figure ({name}.png) and the report ({name}.json); "
                            f"default: nothing kept")
        add_force_option(c, folder=True)
        c.add_argument("--json", action="store_true",
                       help="print robot, recorded_on, notes, episodes, successes, success_rate, interval, "
                            "failures, per_episode as JSON")
        add_episode_options(c)  # --workers, --scheduler, -v: the episodes on Dask
        c.set_defaults(func=_composition)
    return p


def _table(summary: dict) -> list[str]:
    classes = summary["classes"]
    counts = ", ".join(f"{c} {n}" for c, n in zip(classes, summary["class_counts"], strict=True))
    lines = [
        f"RAIL clustering, {summary['mode']} mode: {summary['n_demos']} demos ({counts})",
        f"features: {summary['features']}",
        "",
        f"{'method':<15}{'clusters':>9}{'misclustered':>18}{'ARI':>8}",
    ]
    for method in ("elastic", "agglomerative"):
        m = summary[method]
        mis = f"{m['misclustered']} ({100 * m['misclustered_fraction']:.1f} %)"
        lines.append(f"{method:<15}{m['n_clusters']:>9}{mis:>18}{m['ari']:>8.3f}")
    width = max(len(c) for c in classes) + 2
    for method in ("elastic", "agglomerative"):
        lines += ["", f"{method}: {summary[method]['method']}",
                  "  cluster " + "".join(f"{c:>{width}}" for c in classes)]
        for i, row in enumerate(summary[method]["composition"]):
            lines.append(f"  {i:>7} " + "".join(f"{n:>{width}}" for n in row))  # ids 0..k-1, as in JSON
    timing = summary["timing"]
    lines += ["", f"time: {timing['total_s']:.3f} s (loading {timing['load_s']:.3f} s)"]
    return lines


def run(args) -> int:
    """Run the experiment named by ``args.experiment``; returns the exit status."""
    from ..experiments import plot_rail_experiment, rail_experiment  # the whole stack, when it runs

    if args.plot is not None:
        from ..plotting import figure_path  # the stack is imported when the job runs, as above

        figure_path(args.plot, name="plot")  # a bad name fails before the work, not after
    result = rail_experiment(args.data, mode=args.mode, classes=args.classes, random_state=args.seed)
    summary = result.summary()
    plot = None if args.plot is None else plot_rail_experiment(result, args.plot)
    if args.json:
        print(json.dumps(summary if plot is None else {**summary, "plot": str(plot)}))
    else:
        print("\n".join(_table(summary)))
        if plot is not None:
            print(f"wrote {plot}")
    return 0


def _composition(args) -> int:
    # the whole stack, when it runs; every option checked before anything is recorded
    from ..experiments import check_options, composition_experiment

    parallel = parallel_params(args)
    check_options(args.experiment, episodes=args.episodes, seed=args.seed, demos=args.demos,
                  method=args.method, replan=args.replan, robot=args.robot, record_robot=args.record_robot,
                  planner=args.planner, **parallel)

    check_folder(args.out, "out")
    if args.out is not None and os.path.lexists(args.out) and not Path(args.out).is_dir():
        raise ValueError(f"out: expected a folder to keep the experiment in, got {str(args.out)!r}, which is "
                         "a file")
    verbose_logging(args)
    bars, progress = {}, None
    if show_progress(args):
        from tqdm import tqdm  # a bar on a terminal only

        def progress(stage, done, total, successes):
            if stage not in bars:
                for bar in bars.values():
                    bar.close()
                bars[stage] = tqdm(total=total, desc="recording" if stage == "record" else "episodes",
                                   unit="demonstration" if stage == "record" else "episode", file=sys.stderr)
            bars[stage].update(done - bars[stage].n)
            if successes is not None:
                bars[stage].set_postfix(successes=successes)
    try:
        with _kept(args.out) as folder:
            report = composition_experiment(args.experiment, episodes=args.episodes, seed=args.seed,
                                            demos=args.demos, method=args.method, replan=args.replan,
                                            planner=args.planner,
                                            progress=progress, robot=args.robot,
                                            record_robot=args.record_robot, verbose=args.verbose,
                                            folder=folder, paths=folder is not None, **parallel)
            written = [] if folder is None else _write_results(args, report, folder)
    finally:
        for bar in bars.values():
            bar.close()
    if args.json:
        print(json.dumps({**report, **({"written": [str(p) for p in written]} if written else {})},
                         allow_nan=False))
        return 0
    lo, hi = report["interval"]
    lib = report["library"]
    print(f"experiment {report['experiment']}: {lib['demonstrations']} demonstrations, {lib['primitives']} "
          f"primitives, {lib['skills']} skills; labelled primitive {report['labelled']['pick']} 'pick' and "
          f"{report['labelled']['place']} 'place'")
    for row in report["per_episode"]:
        verdict = "success" if row["success"] else f"failure at step {row['failure']['step']}: " \
            f"{row['failure']['reason']}"
        # the order carried out (the moves the goal leaves free are taken tallest first), not the planner's
        done = [f"({' '.join([s['action'], *s['args']])})" for s in row.get("steps", ()) if s["ok"]]
        print(f"  seed {row['seed']}: carried out {' '.join(done) or '(no steps)'}: {verdict}")
    print(f"{report['scene']} ({report['method']}, on {report['robot']}): {report['successes']}/"
          f"{report['episodes']} = "
          f"{100 * report['success_rate']:.0f} % [{100 * lo:.1f}, {100 * hi:.1f}] (Wilson 95 %)")
    for note in report.get("notes", []):
        print(f"  note: {note}")
    if report["failures"]:
        print("  failures: " + ", ".join(f"{k} {v}" for k, v in sorted(report["failures"].items())))
    for path in written:
        print(f"  wrote {path}")
    return 0


class _kept:
    """The folder a composition experiment writes to: None without ``--out``; else a new folder beside DIR,
    whose files are moved into DIR when the run is whole (a run that fails leaves DIR as it was)."""

    def __init__(self, out):
        self.out = None if out is None else Path(out)
        self.work = None

    def __enter__(self):
        if self.out is None:
            return None
        self.work = Path(tempfile.mkdtemp(prefix=f".{self.out.name}.", dir=self.out.parent))
        return self.work

    def __exit__(self, kind, error, trace):
        if self.work is None:
            return False
        try:
            if kind is None:
                self.out.mkdir(exist_ok=True)
                for path in sorted(self.work.iterdir()):
                    os.replace(path, self.out / path.name)
        finally:
            shutil.rmtree(self.work, ignore_errors=True)
        return False


def _write_results(args, report, folder: Path) -> list:
    """The first episode's figure and the report (as ``--json`` prints it) beside the recordings and the
    library; the files ``--out`` keeps, by their names in DIR."""
    from ..plotting import plot_composed  # matplotlib, when the results are kept

    name = args.experiment
    rows = report["per_episode"]
    figure = plot_composed(rows[0], folder / f"{name}.png",
                           title=f"{report['scene']}, seed {rows[0]['seed']}, {report['method']}")
    for row in rows:
        row.pop("path", None)
        row.pop("step_starts", None)
    (folder / f"{name}.json").write_text(json.dumps(report, allow_nan=False, indent=1) + "\n")
    del figure  # written in folder, moved with the rest
    return [Path(args.out) / p.name for p in sorted(folder.iterdir())]

