"""The user guide's Python blocks run, in order, against the real data."""

from __future__ import annotations

import re
from pathlib import Path

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
