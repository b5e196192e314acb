"""Shared fixtures. Real data is found through one fixture, ``data_dir``."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

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
