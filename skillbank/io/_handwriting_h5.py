"""Reader for 2-D handwriting demonstrations stored as HDF5 groups ``<group>/<i>/{t,x,y}``."""

from __future__ import annotations

import numpy as np

from ..core import Demonstration
from ..core._validation import summarise
from ._confine import ReadBudget
from ._errors import FormatError, as_file, check_clock, check_repair_time, reading, real_array
from ._h5 import open_h5

__all__ = ["read_handwriting_h5", "HANDWRITING_GROUPS"]

HANDWRITING_GROUPS = ("normalized", "smoothed", "unsmoothed")


def _sort_key(name: str):
    # Numeric names sort as numbers ("2" before "10"); anything else after them.
    return (0, int(name), "") if name.isdigit() else (1, 0, name)


def _demo_names(path, h5, group: str) -> list[str]:
    groups = sorted(k for k in h5.keys() if hasattr(h5[k], "keys"))
    if group not in groups:
        found = summarise(map(repr, groups))
        raise FormatError(path, f"expected a group {group!r}, found groups [{found}]")
    return sorted((k for k in h5[group].keys() if hasattr(h5[group][k], "keys")), key=_sort_key)


def _read_one(path, node, group: str, name: str, repair_time, budget) -> Demonstration:
    missing = [k for k in ("t", "x", "y") if k not in node]
    if missing:
        raise FormatError(
            path, f"expected datasets t, x, y in '{group}/{name}', missing {missing}, "
            f"found [{summarise(map(repr, sorted(node.keys())))}]"
        )
    t_ms, x, y = (real_array(path, budget.dataset(node[k], f"{group}/{name}/{k}"), f"'{group}/{name}/{k}'")
                  .ravel() for k in ("t", "x", "y"))
    if not (t_ms.shape == x.shape == y.shape) or t_ms.size == 0:
        raise FormatError(
            path, f"expected non-empty t, x, y of equal length in '{group}/{name}', "
            f"found lengths {t_ms.size}, {x.size}, {y.size}"
        )
    t0 = float(t_ms[0]) / 1000.0
    t, xy, dropped = check_clock(path, (t_ms - t_ms[0]) / 1000.0, np.column_stack([x, y]),
                                 repair_time=repair_time, where=f"demonstration '{group}/{name}' (clock "
                                 f"'{group}/{name}/t')")
    index = int(name) if name.isdigit() else name
    metadata = {
        "source": str(path), "format": "handwriting-h5", "group": group, "index": index, "t0": t0,
    }
    if dropped:
        metadata["dropped_samples"] = dropped
    with reading(path, f"invalid demonstration '{group}/{name}'"):
        return Demonstration(t, {"position": xy}, metadata)


def read_handwriting_h5(path, *, group: str = "normalized", index=None, repair_time=None):
    """Read handwriting demonstrations: groups ``<group>/<i>`` with datasets ``t``, ``x``, ``y``.

    Parameters
    ----------
    path : str or path-like
        The ``.h5`` file.
    group : str, default="normalized"
        Which version of the data: ``"normalized"``, ``"smoothed"`` or
        ``"unsmoothed"`` (any group present in the file is accepted).
    index : int, optional
        Read only demonstration ``<group>/<index>``.
    repair_time : {None, "drop"}, default=None
        Time stamps that repeat, run backwards or never advance are an error
        naming the demonstration and the sample. ``"drop"`` drops samples that
        repeat the previous stamp (keeping the first), counted in
        ``metadata["dropped_samples"]``.

    Returns
    -------
    list of Demonstration, or Demonstration when ``index`` is given
        Stream ``position`` = ``(x, y)`` as float (screen coordinates: y
        points down). ``t`` is in seconds (the file stores milliseconds),
        shifted to start at 0; metadata holds ``source``, ``format``
        (``"handwriting-h5"``), ``group``, ``index`` and ``t0`` (seconds).
        Demonstrations are sorted by their numeric index.

    Raises
    ------
    FormatError
        If the file is not HDF5, or the group or index does not exist (the
        message lists what does), or time stamps do not increase.

    Examples
    --------
    >>> demos = read_handwriting_h5("seed/r_shape.h5")  # doctest: +SKIP
    >>> len(demos), demos[0]["position"].shape  # doctest: +SKIP
    (5, (1000, 2))
    >>> read_handwriting_h5("seed/r_shape.h5", group="unsmoothed", index=2).n_steps  # doctest: +SKIP
    237
    """
    check_repair_time(repair_time)
    p = as_file(path)
    budget = ReadBudget(p)
    with open_h5(p) as h5:
        names = _demo_names(p, h5, group)
        if index is None:
            if not names:
                raise FormatError(p, f"expected demonstrations in group {group!r}, found none")
            return [_read_one(p, h5[group][n], group, n, repair_time, budget) for n in names]
        key = str(index)
        if isinstance(index, bool) or key not in names:
            among = summarise(names, limit=10)
            raise FormatError(p, f"expected an index in group {group!r} among [{among}], got {index!r}")
        return _read_one(p, h5[group][key], group, key, repair_time, budget)
