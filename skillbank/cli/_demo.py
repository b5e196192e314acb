"""``skillbank demo``: the main job on embedded data."""

from __future__ import annotations

import json
from pathlib import Path

from ._options import add_verbose_option, show_progress, verbose_logging
from ._output import add_force_option

__all__ = ["add_parser", "run"]


def add_parser(sub):
    """Register ``demo`` on argparse subparsers ``sub``."""
    p = sub.add_parser("demo", help="run the main job on embedded data (LASA) and write figures")
    p.add_argument("--out", type=Path, default=Path("demo_output"), metavar="DIR",
                   help="folder for figures and summary (default demo_output; new or empty, else --force)")
    add_force_option(p, folder=True)
    p.add_argument("--data", type=Path, default=None,
                   help="shared data folder: use RAIL and the three-button demo instead of LASA")
    p.add_argument("--json", action="store_true", help="print the summary as JSON (and no progress bar)")
    add_verbose_option(p)
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    """Run the main job; returns the exit status."""
    from ..experiments import run_library_demo  # the whole stack, imported when the job runs

    verbose_logging(args)  # robosuite's set-up log only with -v
    summary = run_library_demo(args.out, data=args.data, progress=show_progress(args))
    if args.json:
        print(json.dumps(summary))
    else:
        for r in summary["reuse"]:
            outcome = r["error"] if "error" in r else (
                f"used {r['used']}, constraint error {r['constraint_error']:.2g}, collision {r['collision']}")
            print(f"reuse {r['skill']} ({r['method']}): {outcome}")
        ex = summary.get("executable")
        if ex is not None:
            print(f"executable reproduction ({ex['skill']} on a UR5e, streams {', '.join(ex['streams'])}): "
                  f"{ex['csv']}")
        if summary.get("planning"):
            print(f"tasks never demonstrated, planned over the skills: {summary['planning']}")
        for name, r in (summary.get("composed") or {}).items():
            if name == "skipped":
                print(f"composed tasks in physics: not run ({r})")
                continue
            print(f"composed in physics, experiment {name}: {r['successes']}/{r['episodes']} by robosuite's "
                  f"check in {r['seconds']:.0f} s ({r['command']}; {r['figure']})")
            if r.get("why"):
                print(f"  failed: {r['why']}")
        if summary.get("view"):
            print(f"the library's web view: open {summary['view']}")
        print(f"figures and summary written to {summary['out']}")
        # the run's own clock, not a claim in the docs; each part's time is in summary.md
        print(f"done in {summary['seconds']:.1f} s (each part's time: {summary['summary']}, 'Timing')")
        print(f"open {summary['summary']}")
    return 0
