"""The README and docs/*.md run as written: every fenced block, in order, one file at a time.

Each file runs in a new temporary folder holding ``examples/`` (the inputs the project ships, from
``examples/make_examples.py``), with ``SKILLBANK_DATA`` pointing at the shared data (the ``data_dir``
fixture) and ``skillbank`` and ``python`` on ``PATH`` meaning this interpreter's. A block is run by its
language tag:

- ``bash``: run by ``bash`` with ``set -eo pipefail``, as a user pastes it; it must exit with 0.
- ``console``: its ``$ `` lines are run that way; the other lines are the output shown.
- ``python``: executed in one namespace per file (later blocks see earlier blocks' names).
- ``text``, ``json``, ``lisp``, ``toml``, ``csv``, ``yaml``, ``xml``: shown, not run (output, file
  contents).

An HTML comment on the line before a block changes that (a reason is required where one is asked):

- ``<!-- docs-run: skip: REASON -->``: not run, e.g. it needs a server or takes minutes.
- ``<!-- docs-run: expect-fail: REASON -->``: run; it must fail (a shown error).
- ``<!-- docs-run: file NAME -->``: the block's text is written to ``NAME`` in the folder (a scene,
  a PDDL action) and later blocks read it.
- ``<!-- docs-run: output -->``: a shown block whose every line (spaces collapsed; a line ``...``
  stands for lines left out) is in what the block run before it printed, so figures quoted from a
  command are those of the run.

A long file may be cut into parts that need nothing of each other, each run as its own test (so
pytest-xdist spreads them): ``<!-- docs-run: part NAME -->`` on a line of its own starts (or resumes)
part NAME; the blocks before the first part marker are a prelude that every part runs first.

A block without a language tag is an error: each block says whether it is a command, code or output.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import stat
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FILES = ["README.md", *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").glob("*.md"))]
#: Files not run, with the reason.
EXEMPT = {"docs/benchmarks.md": "the benchmarks' own evaluations (hundreds of robosuite episodes, minutes to "
                                "hours each); every figure there names the command that measured it"}
SHELL = ("bash", "console")
PYTHON = ("python",)
SHOWN = ("text", "json", "lisp", "toml", "csv", "yaml", "xml")
MARKER = re.compile(r"<!--\s*docs-run:\s*(?P<kind>[\w-]+)(?P<rest>.*?)-->", re.S)
LINE_MARKER = re.compile(r"^[ \t]*<!--\s*docs-run:.*?-->[ \t]*$", re.M)
PART = re.compile(r"^<!--\s*docs-run:\s*part\s+(?P<name>[\w-]+)\s*-->[ \t]*$", re.M)
FENCE = re.compile(r"^```(?P<lang>[^\n`]*)\n(?P<code>.*?)^```[ \t]*$", re.S | re.M)
MIN_REASON = 3  # words


@dataclass
class Block:
    """One fenced block of a markdown file."""

    path: str
    line: int
    lang: str
    code: str
    kind: str = "run"  # run, skip, expect-fail, file, output
    arg: str = ""  # the reason, or the file name
    part: str = ""  # the part it belongs to ("": the prelude, or a file without parts)

    def where(self) -> str:
        return f"{self.path}:{self.line} ({self.lang or 'untagged'})"


def blocks(path: str, text: str | None = None) -> list[Block]:
    """The fenced blocks of ``path`` (its ``text`` if given), with their markers."""
    text = (ROOT / path).read_text() if text is None else text
    out = []
    parts = [(m.start(), m.group("name")) for m in PART.finditer(text)]
    for m in FENCE.finditer(text):
        before = text[:m.start()].rstrip().rsplit("\n", 1)[-1]
        block = Block(path, text.count("\n", 0, m.start()) + 1, m.group("lang").strip(), m.group("code"),
                      part=next((name for at, name in reversed(parts) if at < m.start()), ""))
        marker = MARKER.fullmatch(before.strip())
        if marker and marker.group("kind") != "part":
            block.kind = marker.group("kind")
            block.arg = marker.group("rest").strip().lstrip(":").strip()
        out.append(block)
    return out


def problems(bs: list[Block], text: str) -> list[str]:
    """What is wrong with the blocks' tags and markers (empty when all is well)."""
    found = []
    for b in bs:
        if not b.lang:
            found.append(f"{b.where()}: no language tag: say bash, python or console (run), or text, "
                         "json, ... (shown)")
        elif b.lang not in SHELL + PYTHON + SHOWN:
            known = ", ".join(SHELL + PYTHON + SHOWN)
            found.append(f"{b.where()}: unknown language {b.lang!r} (known: {known})")
        if b.kind in ("skip", "expect-fail") and len(b.arg.split()) < MIN_REASON:
            found.append(f"{b.where()}: '{b.kind}' needs a reason of at least {MIN_REASON} words, "
                         f"got {b.arg!r}")
        elif b.kind == "file" and (not re.fullmatch(r"[\w.-]+(/[\w.-]+)*", b.arg)
                                   or ".." in b.arg.split("/")):
            found.append(f"{b.where()}: 'file' needs a relative file name, got {b.arg!r}")
        elif b.kind not in ("run", "skip", "expect-fail", "file", "output"):
            found.append(f"{b.where()}: unknown marker {b.kind!r} (skip, expect-fail, file, output)")
        elif b.kind == "expect-fail" and b.lang not in SHELL + PYTHON:
            found.append(f"{b.where()}: 'expect-fail' on a block that is not run")
        elif b.kind in ("file", "output") and b.lang not in SHOWN:
            found.append(f"{b.where()}: '{b.kind}' on a block that is run (tag it text, json, ...)")
    markers = len(LINE_MARKER.findall(text)) - len(PART.findall(text))  # markers on lines of their own
    marked = sum(b.kind != "run" for b in bs)
    if markers != marked:
        found.append(f"{bs[0].path if bs else '?'}: {markers} docs-run markers, {marked} of them right "
                     "before a block (a marker must be the line before its block's fence)")
    return found


# -- the checks of the convention itself ---------------------------------------------------------------
def test_the_convention_is_checked():
    text = ("```\nls\n```\n<!-- docs-run: skip -->\n```bash\nmake\n```\n"
            "<!-- docs-run: skip: needs a server -->\n```bash\nx\n```\n"
            "<!-- docs-run: file ../x -->\n```json\n{}\n```\n"
            "<!-- docs-run: skip: stray marker -->\n\ntext\n```cpp\nint x;\n```\n")
    bs = blocks("a.md", text)
    assert [(b.kind, b.arg) for b in bs] == [("run", ""), ("skip", ""), ("skip", "needs a server"),
                                             ("file", "../x"), ("run", "")]
    found = problems(bs, text)
    assert len(found) == 5, found
    assert "a.md:1 (untagged): no language tag" in found[0]
    assert "a.md:5 (bash): 'skip' needs a reason of at least 3 words, got ''" in found[1]
    assert "'file' needs a relative file name, got '../x'" in found[2]
    assert "unknown language 'cpp'" in found[3]
    assert "4 docs-run markers, 3 of them right before a block" in found[4]


def test_parts_split_a_file_after_its_prelude():
    text = ("```bash\nln -s a b\n```\n<!-- docs-run: part one -->\n## One\n```bash\necho 1\n```\n"
            "<!-- docs-run: part two -->\n<!-- docs-run: skip: needs a server somewhere -->\n"
            "```bash\nx\n```\n"
            "<!-- docs-run: part one -->\n```python\nprint(1)\n```\n")
    bs = blocks("a.md", text)
    assert [(b.part, b.kind) for b in bs] == [("", "run"), ("one", "run"), ("two", "skip"), ("one", "run")]
    assert parts("a.md", text) == ["one", "two"] and parts("a.md", "```bash\nls\n```\n") == [""]
    assert problems(bs, text) == []


def test_shown_output_is_checked_line_by_line():
    printed = ("method   clusters  misclustered\nelastic      3     20 (13.3 %)\n"
               "agglomerative  3   22 (14.7 %)\n")
    assert missing_lines("elastic 3 20 (13.3 %)\n...\nagglomerative 3 22 (14.7 %)\n", printed) == []
    assert missing_lines("elastic 3 21 (14.0 %)\n", printed) == ["elastic 3 21 (14.0 %)"]


@pytest.mark.parametrize("path", FILES)
def test_every_block_says_what_it_is(path):
    assert problems(blocks(path), (ROOT / path).read_text()) == []


def test_examples_are_those_the_script_writes(tmp_path):
    # the committed text files are what examples/make_examples.py writes now (the binary ones hold no
    # stable bytes: HDF5 and bag writers stamp them)
    done = subprocess.run([sys.executable, str(ROOT / "examples" / "make_examples.py"), str(tmp_path)],
                          capture_output=True, text=True, timeout=120, env=_env(tmp_path / "bin"),
                          check=False)
    assert done.returncode == 0, done.stderr
    for made in sorted(tmp_path.rglob("*")):
        if made.suffix in (".csv", ".json", ".jsonl"):
            shipped = ROOT / "examples" / made.relative_to(tmp_path)
            assert shipped.read_text() == made.read_text(), shipped


# -- running them -------------------------------------------------------------------------------------
def _env(bin_dir: Path, data: Path | None = None) -> dict:
    """The environment of the commands: ``skillbank`` and ``python`` are this interpreter's."""
    bin_dir.mkdir(parents=True, exist_ok=True)
    for name, body in (("skillbank", f'exec "{sys.executable}" -m skillbank.cli "$@"\n'),
                       ("python", f'exec "{sys.executable}" "$@"\n')):
        script = bin_dir / name
        script.write_text("#!/bin/sh\n" + body)
        script.chmod(script.stat().st_mode | stat.S_IXUSR)
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}", "MPLBACKEND": "Agg",
           "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    if data is not None:
        env["SKILLBANK_DATA"] = str(data)
    return env


def _shell(block: Block) -> str:
    if block.lang == "console":
        return "\n".join(line[2:] for line in block.code.splitlines() if line.startswith("$ "))
    return block.code


def _run_shell(block: Block, folder: Path, env: dict) -> tuple[int, str]:
    done = subprocess.run(["bash", "-c", "set -eo pipefail\n" + _shell(block)], cwd=folder, env=env,
                          capture_output=True, text=True, timeout=600, check=False)
    return done.returncode, (done.stdout + "\n" + done.stderr).strip()


def _run_python(block: Block, namespace: dict) -> tuple[int, str]:
    printed = io.StringIO()
    try:
        with contextlib.redirect_stdout(printed):
            exec(compile(block.code, block.where(), "exec"), namespace)  # noqa: S102 - the docs' own code
    except Exception as exc:  # a failing block, reported with where it is
        return 1, f"{printed.getvalue()}\n{type(exc).__name__}: {exc}"
    return 0, printed.getvalue()


def _squeezed(text: str) -> str:
    return " ".join(text.split())


def missing_lines(shown: str, printed: str) -> list[str]:
    """The lines of ``shown`` (an output block) that ``printed`` does not hold, spaces collapsed."""
    have = _squeezed(printed)
    return [line for line in shown.splitlines() if line.strip() and line.strip() != "..."
            and _squeezed(line) not in have]


def parts(path: str, text: str | None = None) -> list[str]:
    """The parts of ``path`` (its ``text`` if given) in the order they first appear; ``[""]`` for a
    file of one piece."""
    text = (ROOT / path).read_text() if text is None else text
    return list(dict.fromkeys(m.group("name") for m in PART.finditer(text))) or [""]


CASES = [pytest.param(path, part, id=f"{path}:{part}" if part else path)
         for path in FILES for part in parts(path)]


def run_file(path: str, folder: Path, data: Path | None, monkeypatch,
             part: str = "") -> list[tuple[Block, float, str]]:
    """Run ``path``'s blocks (the prelude and ``part``'s) in ``folder``; the blocks run, each with its
    time (s) and what it printed. Fails at the first block that exits otherwise than its marker says."""
    (folder / "examples").symlink_to(ROOT / "examples")
    env = _env(folder.parent / "bin", data)
    monkeypatch.chdir(folder)
    for key in ("PATH", "MPLBACKEND"):
        monkeypatch.setenv(key, env[key])
    if data is None:  # a file that does not read the data must not find it either
        env.pop("SKILLBANK_DATA", None)
        monkeypatch.delenv("SKILLBANK_DATA", raising=False)
    else:
        monkeypatch.setenv("SKILLBANK_DATA", env["SKILLBANK_DATA"])
    namespace: dict = {"__name__": "__docs__"}
    ran, last = [], None
    for block in blocks(path):
        if block.part not in ("", part) or block.kind == "skip":
            continue
        if block.kind == "output":
            if last is None:
                pytest.fail(f"{block.where()}: an output block with no block run before it")
            missing = missing_lines(block.code, last[1])
            if missing:
                pytest.fail(f"{block.where()}: shown as the output of {last[0].where()}, but the run did "
                            f"not print {missing}; it printed:\n{last[1][-3000:]}")
            continue
        if block.kind == "file":
            (folder / block.arg).parent.mkdir(parents=True, exist_ok=True)
            (folder / block.arg).write_text(block.code)
            continue
        if block.lang not in SHELL + PYTHON:
            continue
        start = time.perf_counter()
        status, output = (_run_shell(block, folder, env) if block.lang in SHELL
                          else _run_python(block, namespace))
        ran.append((block, time.perf_counter() - start, output))
        last = (block, output)
        if block.kind == "expect-fail" and status == 0:
            pytest.fail(f"{block.where()} is marked expect-fail but exited with 0:\n{block.code}\n"
                        f"{output[-3000:]}")
        if block.kind == "run" and status != 0:
            pytest.fail(f"{block.where()} exited with {status}:\n{block.code}\n--- output ---\n"
                        f"{output[-6000:]}")
    return ran


@pytest.mark.parametrize(("path", "part"), CASES)
def test_docs_run(path, part, request, tmp_path, monkeypatch, capsys):
    if path in EXEMPT:
        pytest.skip(f"{path}: {EXEMPT[path]}")
    text = (ROOT / path).read_text()
    # the shared data only where the file reads it (skipped without it, failed under CI: data_dir)
    data = request.getfixturevalue("data_dir") if "SKILLBANK_DATA" in text else None
    folder = tmp_path / "work"
    folder.mkdir()
    ran = run_file(path, folder, data, monkeypatch, part)
    if os.environ.get("SKILLBANK_DOCS_TIMES"):  # which blocks take the time
        with capsys.disabled():
            slowest = sorted(ran, key=lambda r: -r[1])[:4]
            print(f"\n{path}:{part}: {len(ran)} blocks in {sum(r[1] for r in ran):.1f} s; slowest at lines "
                  + ", ".join(f"{b.line} ({t:.1f} s)" for b, t, _ in slowest))
    numbers = _readme_numbers()
    example = numbers.example(text) if path == "README.md" else None
    printed = "".join(out for b, _, out in ran if b.code == example)
    if printed:  # the figures the README's UR5e example quotes are those this run printed and wrote
        measured = numbers.from_run(printed, folder)
        assert {k: numbers.quoted(text)[k] for k in measured} == measured


def _readme_numbers():
    """docs/readme_numbers.py: a script beside the docs, not part of the package."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("readme_numbers", ROOT / "docs" / "readme_numbers.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
