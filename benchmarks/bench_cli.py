"""Cost of the command line against the library: ``skillbank edit`` beside ``skillbank.editing.lte``.

Run from the repository root (``benchmarks/bench_editing.py`` runs it too, after its own tables)::

    .venv/bin/python benchmarks/bench_cli.py [--sizes 1000 10000 100000] [--metrics-sizes 1000 10000]
        [--repeats 3] [--json PATH]

Case: the smooth 3-D path of ``bench_editing.py`` with N samples (N = 10^3, 10^4, 10^5) on
t in [0, 1], written with ``skillbank.io.write_csv`` to a temporary folder, edited to a new goal
around a sphere that sits on the path (the start is kept). For each N, in the same run:

- library: ``skillbank.editing.lte(Y, Constraints(goal=..., obstacles=[Sphere(...)]), t=t)``
  in this process (best of several repeats);
- CLI in-process: ``skillbank.cli.main(["edit", file, "--goal", ..., "--obstacle", ..., "--json"])``
  in this process, output captured: everything the command does but start-up and imports;
- CLI: the same command as a subprocess of the ``skillbank`` entry point (best of several
  repeats; wall clock from process creation to exit, JSON written to a file), and its peak
  resident memory (GNU ``time -f %M``, else ``os.wait4``: see ``_common.run_child``);
- start-up: ``skillbank --help`` as a subprocess.

Verdict: the CLI is within 1 s of start-up + library when ``CLI - (start-up + library) <= 1 s``.
``--metrics`` (Fréchet and DTW: time proportional to N^2, memory linear) runs at the
``--metrics-sizes`` only; its peak RSS is compared with the plain CLI's at the same N, so
quadratic memory would show as an extra of 8 N^2 bytes (800 MB at 10^4).

Start-up table: wall time and peak RSS of the interpreter alone, of ``--help`` of several
commands, and of importing what the library call needs (``skillbank.editing``) and what
``edit`` needs. Imports table: which heavy packages (scikit-learn, scipy, matplotlib, h5py,
tqdm) are in ``sys.modules`` at exit, for the parser alone, for ``--help`` of commands and for
a real ``edit`` run. The parser must import none of them. No timing is asserted.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import platform
import sys
import tempfile
from pathlib import Path

import numpy as np

from skillbank import Constraints, Demonstration, Sphere
from skillbank.editing import lte
from skillbank.io import write_csv

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_of, run_child  # noqa: E402

SIZES = (1_000, 10_000, 100_000)
METRICS_SIZES = (1_000, 10_000)
GOAL = (1.1, 0.05, -0.02)  # the path's end (1, 0, 0.028) moved by about (0.1, 0.05, -0.05)
SPHERE = (0.5, -0.2, -0.08, 0.05)  # centre on the path at s = 0.5 (0.5, -0.2, -0.080), radius
HEAVY = ("sklearn", "scipy", "matplotlib", "h5py", "tqdm")
EDIT_IMPORTS = "skillbank.cli._main, skillbank.io, skillbank.metrics, skillbank.representations"
_RSS_FROM: set[str] = set()  # where the peak RSS figures came from (see _common.run_child)

# Runs the command line in a child and reports, at exit, which heavy packages it imported.
_PROBE = (
    "import atexit, json, sys\n"
    f"HEAVY = {HEAVY!r}\n"
    "atexit.register(lambda: sys.stderr.write('HEAVY ' + json.dumps(sorted(\n"
    "    {m.split('.')[0] for m in sys.modules} & set(HEAVY))) + '\\n'))\n"
    "from skillbank.cli._main import build_parser, main\n"
    "if sys.argv[1:] == ['--parser-only']:\n"
    "    build_parser()\n"
    "else:\n"
    "    sys.exit(main(sys.argv[1:]))\n"
)


def path(n: int) -> np.ndarray:
    """The path of ``bench_editing.py``."""
    s = np.linspace(0.0, 1.0, n)
    return np.column_stack([s, 0.2 * np.sin(3 * np.pi * s), 0.1 * np.cos(5 * s)])


def cli() -> list[str]:
    """The ``skillbank`` entry point beside this interpreter, else ``python -m skillbank.cli``."""
    script = Path(sys.executable).parent / "skillbank"
    return [str(script)] if script.is_file() else [sys.executable, "-m", "skillbank.cli"]


def edit_args(csv: Path, *, metrics: bool = False) -> list[str]:
    args = ["edit", str(csv), "--goal", ",".join(map(str, GOAL)),
            "--obstacle", "sphere:" + ",".join(map(str, SPHERE)), "--json"]
    return args + ["--metrics"] if metrics else args


def best_child(cmd, repeats: int, stdout=None):
    """Shortest wall time and largest peak RSS (MB) of ``repeats`` runs of ``cmd``; fails loudly."""
    runs = [run_child(cmd, stdout=stdout) for _ in range(repeats)]
    bad = [r for r in runs if r.returncode != 0]
    if bad:
        cmd_text = " ".join(map(str, cmd))
        raise RuntimeError(f"{cmd_text} exited with {bad[0].returncode}: {bad[0].stderr.strip()}")
    _RSS_FROM.add(runs[0].rss_from)
    return min(r.seconds for r in runs), max(r.max_rss_mb for r in runs)


def bench_startup(repeats: int) -> list[dict]:
    """Wall time and peak RSS of start-up alone: interpreter, ``--help``, the imports of each side."""
    py, sb = [sys.executable], cli()
    cases = [
        ("python -c pass (interpreter)", py + ["-c", "pass"]),
        ("skillbank --help", sb + ["--help"]),
        ("skillbank edit --help", sb + ["edit", "--help"]),
        ("skillbank segment --help", sb + ["segment", "--help"]),
        ("skillbank library --help", sb + ["library", "--help"]),
        ("import skillbank.editing (the library call)", py + ["-c", "import skillbank.editing"]),
        ("import what edit imports", py + ["-c", f"import {EDIT_IMPORTS}"]),
        ("import sklearn.base (for reference; edit does not import it)", py + ["-c", "import sklearn.base"]),
    ]
    rows = []
    for name, cmd in cases:
        seconds, rss = best_child(cmd, repeats)
        rows.append({"what": name, "seconds": seconds, "max_rss_mb": rss})
    return rows


def heavy_imports(argv) -> list[str]:
    """The heavy packages a ``skillbank`` child imports for ``argv`` (``["--parser-only"]``: the parser)."""
    run = run_child([sys.executable, "-c", _PROBE, *map(str, argv)])
    lines = [line for line in run.stderr.splitlines() if line.startswith("HEAVY ")]
    if run.returncode != 0 or not lines:
        argv_text = " ".join(map(str, argv))
        raise RuntimeError(f"skillbank {argv_text}: exit {run.returncode}: {run.stderr.strip()}")
    return json.loads(lines[-1][len("HEAVY "):])


def bench_imports(csv: Path) -> list[dict]:
    cases = [
        ("parser only (build_parser)", ["--parser-only"]),
        ("skillbank --help", ["--help"]),
        ("skillbank segment --help", ["segment", "--help"]),
        ("skillbank library --help", ["library", "--help"]),
        ("skillbank cluster --help", ["cluster", "--help"]),
        ("skillbank edit --help", ["edit", "--help"]),
        ("skillbank edit (run, 1,000 points)", edit_args(csv)),
        ("skillbank edit --metrics (run, 1,000 points)", edit_args(csv, metrics=True)),
    ]
    return [{"what": name, "heavy": heavy_imports(argv)} for name, argv in cases]


def constraints() -> Constraints:
    return Constraints(goal=list(GOAL), obstacles=[Sphere(SPHERE[:3], SPHERE[3])])


def bench_edit(sizes, metrics_sizes, repeats: int, folder: Path, startup_s: float, imports_s: float):
    """Per N: the library call, the command in-process and as a subprocess, and ``--metrics``."""
    from skillbank.cli import main as cli_main  # pulls in the representations (scikit-learn)

    c, rows = constraints(), []
    for n in sorted(set(sizes) | set(metrics_sizes)):
        t, Y = np.linspace(0.0, 1.0, n), path(n)
        csv = write_csv(Demonstration(t, {"position": Y}), folder / f"path_{n}.csv")
        out = folder / f"edit_{n}.json"
        reps = repeats if n <= 10_000 else max(1, repeats - 1)
        row = {"n": n}
        if n in sizes:
            lib_s, res = best_of(lambda Y=Y, t=t: lte(Y, c, t=t), max(reps, 3))

            def in_process(csv=csv):
                with contextlib.redirect_stdout(io.StringIO()):
                    if cli_main(edit_args(csv)) != 0:
                        raise RuntimeError(f"skillbank edit {csv} failed in-process")

            in_process()  # once untimed: the command imports its modules on first use
            inproc_s, _ = best_of(in_process, reps)
            cli_s, rss = best_child(cli() + edit_args(csv), reps, stdout=out)
            doc = json.loads(out.read_text())
            diff = float(np.abs(np.asarray(doc["trajectory"]) - res.Y).max())
            row.update(library_s=lib_s, library_success=bool(res.success), cli_inprocess_s=inproc_s,
                       cli_s=cli_s, cli_max_rss_mb=rss, startup_s=startup_s, imports_s=imports_s,
                       overhead_s=cli_s - (startup_s + lib_s), over_imports_s=cli_s - (imports_s + lib_s),
                       cli_constraint_error=doc["constraint_error"], cli_collision=doc["collision"],
                       cli_vs_library_max_diff=diff)
            row["within_1s"] = bool(row["overhead_s"] <= 1.0)
        if n in metrics_sizes:
            m_reps = max(1, min(reps, 2))
            met_s, met_rss = best_child(cli() + edit_args(csv, metrics=True), m_reps, stdout=out)
            metrics = json.loads(out.read_text())["metrics"]
            if "cli_s" not in row:  # the plain run, to subtract
                row["cli_s"], row["cli_max_rss_mb"] = best_child(cli() + edit_args(csv), m_reps, stdout=out)
            row.update(metrics_cli_s=met_s, metrics_max_rss_mb=met_rss, metrics_extra_s=met_s - row["cli_s"],
                       metrics_extra_rss_mb=met_rss - row["cli_max_rss_mb"], frechet=metrics["frechet"],
                       dtw=metrics["dtw"])
        rows.append(row)
    return rows


def print_tables(startup, imports, rows) -> None:
    rss_from = " and ".join(sorted(_RSS_FROM))
    print(f"\nStart-up (subprocess, best wall time; peak RSS of the child, from {rss_from}):\n")
    print("| what | wall (s) | peak RSS (MB) |\n|---|---:|---:|")
    for r in startup:
        print(f"| {r['what']} | {r['seconds']:.3f} | {r['max_rss_mb']:.0f} |")
    print("\nHeavy packages imported (sys.modules at exit):\n")
    print("| command | scikit-learn, scipy, matplotlib, h5py, tqdm imported |\n|---|---|")
    for r in imports:
        print(f"| {r['what']} | {', '.join(r['heavy']) or 'none'} |")
    edit_rows = [r for r in rows if "library_s" in r]
    if edit_rows:
        print("\n`skillbank edit FILE.csv --goal ... --obstacle sphere:... --json` against `lte` in-process "
              "(start-up = `skillbank --help`):\n")
        print("| N | library lte (s) | CLI in-process (s) | CLI (s) | CLI - (start-up + library) (s) "
              "| within 1 s | CLI - (edit's imports + library) (s) | CLI peak RSS (MB) | CLI vs library |")
        print("|---:|---:|---:|---:|---:|:---:|---:|---:|---:|")
        for r in edit_rows:
            verdict = "yes" if r["within_1s"] else "no"
            print(f"| {r['n']:,} | {r['library_s']:.4f} | {r['cli_inprocess_s']:.3f} | {r['cli_s']:.3f} "
                  f"| {r['overhead_s']:.3f} | {verdict} | {r['over_imports_s']:.3f} "
                  f"| {r['cli_max_rss_mb']:.0f} | {r['cli_vs_library_max_diff']:.1g} |")
        r = edit_rows[0]
        print(f"\nstart-up = `skillbank --help` = {r['startup_s']:.3f} s; edit's imports "
              f"(`python -c \"import {EDIT_IMPORTS}\"`) = {r['imports_s']:.3f} s; "
              "last column: largest difference between the CLI's and the library's paths")
    met_rows = [r for r in rows if "metrics_cli_s" in r]
    if met_rows:
        print("\n`skillbank edit ... --json --metrics` (Fréchet and DTW, O(N^2) time):\n")
        print("| N | CLI --metrics (s) | metrics alone (s) | peak RSS (MB) | RSS over plain CLI (MB) "
              "| Fréchet | DTW |")
        print("|---:|---:|---:|---:|---:|---:|---:|")
        for r in met_rows:
            print(f"| {r['n']:,} | {r['metrics_cli_s']:.3f} | {r['metrics_extra_s']:.3f} "
                  f"| {r['metrics_max_rss_mb']:.0f} | {r['metrics_extra_rss_mb']:+.0f} | {r['frechet']:.3g} "
                  f"| {r['dtw']:.4g} |")


def run(sizes=SIZES, metrics_sizes=METRICS_SIZES, repeats: int = 3) -> dict:
    """Measure and print every table; return the figures."""
    print(f"\nCLI: {' '.join(cli())}; python {platform.python_version()}, numpy {np.__version__}")
    with tempfile.TemporaryDirectory(prefix="bench_cli_") as tmp:
        folder = Path(tmp)
        startup = bench_startup(repeats)
        small = write_csv(Demonstration(np.linspace(0.0, 1.0, 1000), {"position": path(1000)}),
                          folder / "imports.csv")
        imports = bench_imports(small)
        help_s = next(r["seconds"] for r in startup if r["what"] == "skillbank --help")
        imports_s = next(r["seconds"] for r in startup if r["what"] == "import what edit imports")
        rows = bench_edit(sizes, metrics_sizes, repeats, folder, help_s, imports_s)
    print_tables(startup, imports, rows)
    return {"startup": startup, "imports": imports, "edit": rows, "rss_from": sorted(_RSS_FROM)}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=list(SIZES))
    parser.add_argument("--metrics-sizes", type=int, nargs="*", default=list(METRICS_SIZES))
    parser.add_argument("--repeats", type=int, default=3, help="subprocess repeats (best of)")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    result = run(args.sizes, args.metrics_sizes, args.repeats)
    if args.json:
        args.json.write_text(json.dumps(result, indent=2, default=float))


if __name__ == "__main__":
    main()
