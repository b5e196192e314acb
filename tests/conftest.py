"""Shared fixtures. Real data is found through one fixture, ``data_dir``."""

from __future__ import annotations

import os
import sqlite3
from pathlib import Path

import pytest

from skillbank.cli import _main

_DEFAULT = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


def _data_root() -> Path:
    env = os.environ.get("SKILLBANK_DATA")
    return Path(env) if env else _DEFAULT.resolve()


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """The shared data folder: ``$SKILLBANK_DATA``, else ``../shared/data``.

    Skips when absent, but fails under CI, where the data must be present.
    """
    root = _data_root()
    if not (root / "seed").is_dir():
        message = (
            f"real data not found at {root}: set SKILLBANK_DATA to the shared data folder "
            "(with seed/ and rail/)"
        )
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    return root


@pytest.fixture
def cli(capsys):
    """``cli(*argv) -> (exit status, stdout, stderr)`` of ``skillbank argv...`` (the real entry point)."""

    def call(*argv):
        capsys.readouterr()
        code = _main.main([str(a) for a in argv])
        out, err = capsys.readouterr()
        return code, out, err

    return call


def _rows(path) -> dict:
    conn = sqlite3.connect(path)
    try:
        tables = [r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table' "
                                             "ORDER BY name")]
        return {t: conn.execute(f'SELECT * FROM "{t}" ORDER BY rowid').fetchall() for t in tables}  # noqa: S608
    finally:
        conn.close()


@pytest.fixture(scope="session")
def table_rows():
    """``table_rows(path)``: every row of every table of a SQLite file; equal means nothing changed."""
    return _rows
