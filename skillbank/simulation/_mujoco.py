"""MuJoCo, imported when a simulation runs: without the extra, one line says what to install."""

from __future__ import annotations

__all__ = ["import_mujoco", "MISSING"]

#: What a user without the extra reads.
MISSING = "simulation needs MuJoCo: pip install 'skillbank[sim]'"


def import_mujoco():
    """The ``mujoco`` module, or an ImportError of one line naming the extra.

    Examples
    --------
    >>> import_mujoco().__version__  # the version the sim extra pins
    '3.3.7'
    """
    try:
        import mujoco  # the optional extra skillbank[sim], only when a simulation runs
    except ImportError:
        raise ImportError(MISSING) from None
    return mujoco
