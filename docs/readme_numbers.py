"""The README's figures quoted from a command, taken from a run of that command.

The README's UR5e example (the bash block with ``--robot ur5e``) is run as
written, in a temporary folder holding the three-button demonstration, and
its comment lines are compared with (``check``) or rewritten from
(``rewrite``) what the commands printed and wrote:

- ``#   -> <the line the reuse printed: N samples over T s from t = 0; streams ...>``
- ``URScript: N servoj steps`` in a comment (the ``servoj`` calls of the script written)

and the figures paragraph's cuts come from segmenting the seed data as
``docs/make_figures.py`` does (R demo 3 with the paper's parameters, the
three-button demonstration with the defaults and with the paper's rule).

``docs/make_figures.py`` rewrites the README; ``tests/test_guide.py`` checks it.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
import tempfile
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"
DEMO = "three_button_pressing_demo.h5"
SAMPLES = re.compile(r"(#\s+-> )(\d+ samples over [\d.]+ s from t = 0; streams [\w, ]+)")
SERVOJ = re.compile(r"(URScript: )(\d+)( servoj steps)")
R_CUTS = re.compile(r"(2 changepoints, at samples )(\d+) and (\d+)")
BUTTON_CUTS = re.compile(r"(6 segments, cut at )([\d.]+) s and ([\d.]+) s"
                         r"( \(the gripper closing and opening\) and at )"
                         r"([\d.]+) s, ([\d.]+) s and ([\d.]+) s")
PAPER_CUTS = re.compile(r"(The paper's rule cuts )([\d.]+) s, ([\d.]+) s and ([\d.]+) s")


def example(text: str) -> str:
    """The README's bash block that reuses a skill on the UR5e."""
    blocks = re.findall(r"```bash\n(.*?)```", text, flags=re.S)
    found = [b for b in blocks if "--robot ur5e" in b and "press.script" in b]
    if len(found) != 1:
        raise ValueError(f"README: expected one bash block with the UR5e example, found {len(found)}")
    return found[0]


def commands(block: str) -> list[list[str]]:
    """The block's skillbank commands as argument lists: continuations joined, comments dropped,
    ``for id in ...; do ...; done`` expanded, and ``...`` replaced by the first reuse's options."""
    lines = block.replace("\\\n", " ").splitlines()
    out, first_reuse = [], None
    for line in lines:
        loop = re.match(r"\s*for (\w+) in ([\w ]+); do (.*); done", line)
        body = [loop.group(3).replace(f"${loop.group(1)}", v) for v in loop.group(2).split()] if loop \
            else [line]
        for text in body:
            args = shlex.split(text, comments=True)
            if not args or args[0] != "skillbank":
                continue
            args = args[1:]
            if args[:2] == ["library", "reuse"]:
                if "..." in args:  # "the same options" as the first reuse, with this one's output
                    i = args.index("...")
                    k = first_reuse.index("--out") if "--out" in first_reuse else len(first_reuse)
                    same = first_reuse[:k] + first_reuse[k + 2:]
                    args = args[:i] + same[i:] + args[i + 1:]
                elif first_reuse is None:
                    first_reuse = args
            out.append(args)
    return out


def run(data: Path, folder: Path) -> dict:
    """Run the README's UR5e example in ``folder``; the figures the README quotes from it."""
    from skillbank.cli._main import main  # the real entry point, as the user runs it

    (folder / DEMO).symlink_to(Path(data) / "seed" / DEMO)
    printed = []
    cwd = Path.cwd()
    os.chdir(folder)
    try:
        for args in commands(example(README.read_text())):
            if "--format" in args:  # a rosbag folder: nothing the README quotes from it
                continue
            buffer = io.StringIO()
            with contextlib.redirect_stdout(buffer):
                status = main(args)
            if status != 0:
                raise RuntimeError(f"skillbank {' '.join(args)} exited with {status}")
            printed.append(buffer.getvalue())
    finally:
        os.chdir(cwd)
    return from_run("".join(printed), folder)


def from_run(printed: str, folder: Path) -> dict:
    """The figures the UR5e example quotes, from what its commands ``printed`` and wrote in ``folder``
    (also what ``tests/test_docs_run.py`` checks after running the README)."""
    line = next(m.group(1) for m in re.finditer(r"^\s+(\d+ samples over .*)$", printed, flags=re.M))
    script = (Path(folder) / "press.script").read_text()
    steps = sum(1 for s in script.splitlines() if s.strip().startswith("servoj("))
    return {"samples": line.strip(), "servoj": steps}


def cuts(data: Path) -> dict:
    """The keypoints the figures paragraph quotes: R demo 3 (the paper's parameters and rule, samples)
    and the three-button demonstration (defaults; the paper's rule), in seconds from its start."""
    import skillbank.io as sio  # the package, only when the figures are measured
    from skillbank.segmentation import segment

    r = segment(sio.read_handwriting_h5(Path(data) / "seed" / "r_shape.h5", index=3), window=16, min_size=64,
                threshold=0.16, combine="product")
    demo = sio.read_robot_h5(Path(data) / "seed" / DEMO)
    button, paper = segment(demo), segment(demo, combine="product")
    since = [[f"{x:.2f}" for x in res.keypoint_times - demo.t[0]] for res in (button, paper)]
    return {"r": [int(k) for k in r.keypoints], "button": since[0], "paper": since[1]}


def quoted(text: str) -> dict:
    """The figures the README quotes now."""
    block = example(text)
    button = BUTTON_CUTS.search(text).groups()
    return {"samples": SAMPLES.search(block).group(2), "servoj": int(SERVOJ.search(block).group(2)),
            "r": [int(k) for k in R_CUTS.search(text).groups()[1:]],
            "button": [button[1], *button[4:], button[2]],
            "paper": list(PAPER_CUTS.search(text).groups()[1:])}


def rewrite(text: str, numbers: dict) -> str:
    """``text`` with the quoted figures replaced by ``numbers`` (from :func:`measure`).

    Raises
    ------
    ValueError
        If the run found other counts than the prose describes (then a person rewrites the prose).
    """
    shapes = {"r": 2, "button": 5, "paper": 3}
    for key, n in shapes.items():
        if len(numbers[key]) != n:
            raise ValueError(f"{key}: the README describes {n} cuts, the run found {numbers[key]}")
    text = SAMPLES.sub(lambda m: m.group(1) + numbers["samples"], text)
    text = SERVOJ.sub(lambda m: f"{m.group(1)}{numbers['servoj']}{m.group(3)}", text)
    text = R_CUTS.sub(lambda m: f"{m.group(1)}{numbers['r'][0]} and {numbers['r'][1]}", text)
    b = numbers["button"]  # the gripper closing and opening first and last, the three presses between
    text = BUTTON_CUTS.sub(lambda m: f"{m.group(1)}{b[0]} s and {b[4]} s{m.group(4)}{b[1]} s, {b[2]} s and "
                           f"{b[3]} s", text)
    p = numbers["paper"]
    return PAPER_CUTS.sub(lambda m: f"{m.group(1)}{p[0]} s, {p[1]} s and {p[2]} s", text)


def measure(data: Path) -> dict:
    """Every figure the README quotes from a run: :func:`run` in a temporary folder, and :func:`cuts`."""
    with tempfile.TemporaryDirectory() as tmp:
        return {**run(data, Path(tmp)), **cuts(data)}
