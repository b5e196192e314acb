"""The one input validator every public entry point goes through.

Every check raises :class:`ValueError` naming the argument, what was expected
and what was received, so that users never see a traceback from deep inside
numpy or scipy.
"""

from __future__ import annotations

import numpy as np

__all__ = ["check_array", "check_time", "check_positive", "check_fraction"]


def _describe(value) -> str:
    shape = getattr(value, "shape", None)
    if shape is not None:
        return f"an array of shape {tuple(shape)} and dtype {getattr(value, 'dtype', '?')}"
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{type(value).__name__} {text}"


def check_array(
    value,
    *,
    name: str,
    ndim: int | tuple[int, ...] = 2,
    min_samples: int = 1,
    n_dims: int | None = None,
    as_2d: bool = False,
) -> np.ndarray:
    """Convert ``value`` to a finite float64 array and check its shape.

    Parameters
    ----------
    value : array-like
        The user's input.
    name : str
        Argument name, used in error messages.
    ndim : int or tuple of int, default=2
        Accepted numbers of dimensions.
    min_samples : int, default=1
        Minimum length of the first axis.
    n_dims : int, optional
        Required length of the second axis, if any.
    as_2d : bool, default=False
        Return a 1-D input as a column ``(n_steps, 1)``.

    Returns
    -------
    ndarray of float64

    Raises
    ------
    ValueError
        If the input cannot be converted, has the wrong ndim, holds NaN or
        inf, or is too short.

    Examples
    --------
    >>> check_array([[0.0, 1.0], [2.0, 3.0]], name="Y").shape
    (2, 2)
    """
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"{name}: expected an array of real numbers, got {_describe(value)} "
            f"which cannot be converted to float ({exc})"
        ) from None
    allowed = (ndim,) if isinstance(ndim, int) else tuple(ndim)
    if arr.ndim not in allowed:
        want = " or ".join(f"{d}-D" for d in allowed)
        raise ValueError(f"{name}: expected a {want} array, got {arr.ndim}-D with shape {arr.shape}")
    if as_2d and arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim >= 1 and arr.shape[0] < min_samples:
        raise ValueError(
            f"{name}: expected at least {min_samples} samples, got {arr.shape[0]}"
        )
    if n_dims is not None and arr.ndim == 2 and arr.shape[1] != n_dims:
        raise ValueError(f"{name}: expected {n_dims} columns, got {arr.shape[1]}")
    if arr.ndim == 2 and arr.shape[1] == 0:
        raise ValueError(f"{name}: expected at least one column, got shape {arr.shape}")
    finite = np.isfinite(arr)
    if not finite.all():
        bad = np.argwhere(~finite)
        first = tuple(int(i) for i in bad[0])
        kind = "NaN" if np.isnan(arr[first]) else "inf"
        raise ValueError(
            f"{name}: expected finite values, got {len(bad)} non-finite value(s) "
            f"({kind} first at index {first if len(first) > 1 else first[0]})"
        )
    return arr


def check_time(t, *, name: str = "t", min_samples: int = 1, n_steps: int | None = None):
    """Check a time vector: 1-D, finite, strictly increasing.

    Parameters
    ----------
    t : array-like of shape (n_steps,)
        Time stamps in seconds.
    name : str, default="t"
        Argument name for error messages.
    min_samples : int, default=1
        Minimum number of samples.
    n_steps : int, optional
        Required length.

    Returns
    -------
    ndarray of float64, shape (n_steps,)

    Examples
    --------
    >>> check_time([0.0, 0.1, 0.2]).shape
    (3,)
    """
    arr = check_array(t, name=name, ndim=1, min_samples=min_samples)
    if n_steps is not None and arr.shape[0] != n_steps:
        raise ValueError(f"{name}: expected {n_steps} samples to match the data, got {arr.shape[0]}")
    if arr.shape[0] > 1:
        steps = np.diff(arr)
        bad = np.flatnonzero(steps <= 0)
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"{name}: expected strictly increasing time, got {name}[{i + 1}]={float(arr[i + 1])!r} "
                f"after {name}[{i}]={float(arr[i])!r} ({bad.size} non-increasing step(s))"
            )
    return arr


def check_positive(value, *, name: str, integer: bool = False, allow_zero: bool = False):
    """Check a scalar hyperparameter is a positive (optionally integer) number.

    Examples
    --------
    >>> check_positive(3, name="window", integer=True)
    3
    """
    kind = "an integer" if integer else "a number"
    bound = ">= 0" if allow_zero else "> 0"
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name}: expected {kind} {bound}, got {_describe(value)}")
    if integer and float(value) != int(value):
        raise ValueError(f"{name}: expected an integer {bound}, got {value!r}")
    if not np.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
        raise ValueError(f"{name}: expected {kind} {bound}, got {value!r}")
    return int(value) if integer else float(value)


def check_fraction(value, *, name: str, low: float = 0.0, high: float = 1.0):
    """Check a scalar lies in the closed interval ``[low, high]``.

    Examples
    --------
    >>> check_fraction(0.2, name="threshold")
    0.2
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name}: expected a number in [{low}, {high}], got {_describe(value)}")
    if not np.isfinite(value) or not (low <= value <= high):
        raise ValueError(f"{name}: expected a number in [{low}, {high}], got {value!r}")
    return float(value)
