"""The user guide has code, and the figures the README quotes are those of a run.

The guide's and the README's blocks themselves run in ``tests/test_docs_run.py``.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

GUIDE = Path(__file__).resolve().parents[1] / "docs" / "guide.md"


def _blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", GUIDE.read_text(), flags=re.S)


def test_guide_has_code():
    assert len(_blocks()) >= 10


README = GUIDE.parents[1] / "README.md"


def _readme_numbers():
    """docs/readme_numbers.py, the module that takes the README's quoted figures from a run."""
    import importlib.util  # a script beside the docs, not part of the package

    spec = importlib.util.spec_from_file_location("readme_numbers", GUIDE.parent / "readme_numbers.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_readme_cuts_are_those_of_a_run(data_dir):
    # the UR5e example's figures are checked where the README is run (tests/test_docs_run.py)
    numbers = _readme_numbers()
    measured = numbers.cuts(data_dir)
    # run `.venv/bin/python docs/make_figures.py` to rewrite them after a change of behaviour
    assert {k: numbers.quoted(README.read_text())[k] for k in measured} == measured


def test_readme_numbers_rewrite_what_it_quotes():
    numbers = _readme_numbers()
    text = README.read_text()
    new = {"samples": "7 samples over 0.5 s from t = 0; streams position", "servoj": 3, "r": [1, 2],
           "button": ["1.00", "2.00", "3.00", "4.00", "5.00"], "paper": ["1.50", "2.50", "3.50"]}
    assert numbers.quoted(numbers.rewrite(text, new)) == new
    with pytest.raises(ValueError, match=r"button: the README describes 5 cuts, the run found \['1.00'\]"):
        numbers.rewrite(text, {**new, "button": ["1.00"]})
