"""The user guide's Python blocks run, in order, against the real data."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

GUIDE = Path(__file__).resolve().parents[1] / "docs" / "guide.md"


def _blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", GUIDE.read_text(), flags=re.S)


def test_guide_has_code():
    assert len(_blocks()) >= 10


def test_guide_runs(data_dir, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("SKILLBANK_DATA", str(data_dir))
    namespace: dict = {"__name__": "guide"}
    for k, code in enumerate(_blocks()):
        exec(compile(code, f"{GUIDE.name}[block {k}]", "exec"), namespace)  # noqa: S102
    assert (tmp_path / "figures" / "segments.png").is_file()
    assert (tmp_path / "backup" / "manifest.json").is_file()
    out = capsys.readouterr().out
    assert "t: expected strictly increasing" in out


README = GUIDE.parents[1] / "README.md"


def _readme_numbers():
    """docs/readme_numbers.py, the module that takes the README's quoted figures from a run."""
    import importlib.util  # a script beside the docs, not part of the package

    spec = importlib.util.spec_from_file_location("readme_numbers", GUIDE.parent / "readme_numbers.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_readme_python_runs_as_written(data_dir, tmp_path, monkeypatch, capsys):
    # as a reader runs it: beside a copy of the three-button file, with SKILLBANK_DATA pointing at the data
    work = tmp_path / "work"
    work.mkdir()
    (work / "three_button_pressing_demo.h5").symlink_to(data_dir / "seed" / "three_button_pressing_demo.h5")
    monkeypatch.chdir(work)
    monkeypatch.setenv("SKILLBANK_DATA", str(data_dir))
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)
    assert len(blocks) >= 5
    for k, code in enumerate(blocks):  # each block on its own: none leans on another's names
        exec(compile(code, f"README.md[block {k}]", "exec"), {"__name__": "readme"})  # noqa: S102
    script = (work / "press.script").read_text()
    assert "servoj(" in script and (work / "three_button.png").is_file()
    assert "joints" in capsys.readouterr().out


def test_readme_figures_are_those_of_a_run(data_dir, tmp_path):
    numbers = _readme_numbers()
    measured = {**numbers.run(data_dir, tmp_path), **numbers.cuts(data_dir)}
    # run `.venv/bin/python docs/make_figures.py` to rewrite them after a change of behaviour
    assert numbers.quoted(README.read_text()) == measured


def test_readme_numbers_rewrite_what_it_quotes():
    numbers = _readme_numbers()
    text = README.read_text()
    new = {"samples": "7 samples over 0.5 s from t = 0; streams position", "servoj": 3, "r": [1, 2],
           "button": ["1.00", "2.00", "3.00", "4.00", "5.00"], "paper": ["1.50", "2.50", "3.50"]}
    assert numbers.quoted(numbers.rewrite(text, new)) == new
    with pytest.raises(ValueError, match=r"button: the README describes 5 cuts, the run found \['1.00'\]"):
        numbers.rewrite(text, {**new, "button": ["1.00"]})
