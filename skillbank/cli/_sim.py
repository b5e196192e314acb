"""``skillbank sim record``: scripted demonstrations in robosuite, written in robomimic's HDF5 layout.

Exit status: 0 when the file was written, 2 on bad input or when too few episodes succeeded (nothing is
written then).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from ._options import check_folder, show_progress

__all__ = ["add_parser"]


def add_parser(sub):
    """Register ``skillbank sim`` and its sub-command ``record``.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="skillbank")
    >>> add_parser(parser.add_subparsers(dest="command"))  # doctest: +ELLIPSIS
    ArgumentParser(...)
    """
    p = sub.add_parser("sim", help="robosuite environments: record scripted demonstrations (needs "
                                   "skillbank[sim])")
    inner = p.add_subparsers(dest="sim_command", required=True)
    r = inner.add_parser("record", help="record successful scripted demonstrations of a robosuite task on "
                                        "the UR5e into a robomimic HDF5 file (library add reads it)")
    r.add_argument("env", metavar="robosuite:TASK", help="the task, e.g. robosuite:Lift or robosuite:Stack")
    r.add_argument("--episodes", type=int, default=10, help="successful episodes to keep (default 10)")
    r.add_argument("--seed", type=int, default=0,
                   help="seeds the placements and the demonstrator (default 0)")
    r.add_argument("--max-tries", type=int, default=None,
                   help="episodes run at most (default 3 x --episodes); fewer successes write nothing")
    r.add_argument("--out", type=Path, required=True, help="the HDF5 file to write (must not exist)")
    r.add_argument("--json", action="store_true",
                   help="print env, episodes, tried, seed, out, samples as JSON")
    r.set_defaults(func=_record)
    return p


def _record(args) -> int:
    from tqdm import tqdm  # core dependency; the bar only when asked

    from ..simulation import record  # robosuite (the sim extra) is imported when the environment is made

    check_folder(args.out, "out")  # record checks the task, the counts and the file before robosuite starts
    with tqdm(total=args.episodes, desc="recording", unit="episode", file=sys.stderr,
              disable=not show_progress(args)) as bar:
        def tick(kept, tried):
            bar.update(kept - bar.n)
            bar.set_postfix_str(f"{tried} tried")

        report = record(args.env, episodes=args.episodes, out=args.out, seed=args.seed,
                        max_tries=args.max_tries, progress=tick)
    if args.json:
        print(json.dumps(report))
    else:
        print(f"{args.out}: {report['episodes']} successful episode(s) of {report['env']} "
              f"({report['tried']} tried, seed {report['seed']}), {report['samples']} samples")
    return 0
