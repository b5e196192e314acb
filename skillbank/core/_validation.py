"""The one input validator every public entry point goes through.

Every check raises :class:`ValueError` naming the argument, what was expected
and what was received, so that users never see a traceback from deep inside
numpy or scipy.

Numbers at the edges
--------------------
Every array, time stamp, obstacle size and scalar hyperparameter is bounded
by :data:`MAX_MAGNITUDE` (``|x| <= 1e100``) and must be real (complex input is
rejected by name, never silently cast). Inside that bound the solvers can
square and multiply coordinates; what can still overflow (a huge path on a
tiny time step, say) is caught where it happens: the public entry points run
their numerics under :func:`numerical_errors`, which turns floating-point
trouble and the warnings of numpy and scipy into one :class:`ValueError`
naming the step, and :func:`check_finite_result` checks what they return.
Long lists in messages are cut by :func:`summarise`.
"""

from __future__ import annotations

import os
import warnings
from contextlib import contextmanager

import numpy as np

__all__ = [
    "MAX_MAGNITUDE", "check_array", "check_time", "check_positive", "check_fraction",
    "check_finite_result", "numerical_errors", "summarise", "check_id",
]

#: Largest magnitude accepted for a coordinate, a time stamp, an obstacle's size or a scalar
#: hyperparameter. Squares of such numbers (distances, variances, dot products) stay below 1e200,
#: which leaves a factor of 1e108 of float64's range (1.8e308) for what the solvers multiply them
#: by: sums over millions of samples, powers of the number of samples (the elastic map's bending
#: weight grows as (N - 1)^3, a jerk as 1 / dt^3), hyperparameters. The square root of the range,
#: 1e154, would leave no room at all. Real data (metres, millimetres, pixels, epoch seconds ~1.7e9
#: or even epoch nanoseconds ~1.7e18) is far inside.
MAX_MAGNITUDE = 1e100

#: Most items a message lists before it says how many more there are.
_LISTED = 3


def _describe(value) -> str:
    shape = getattr(value, "shape", None)
    if shape is not None:
        return f"an array of shape {tuple(shape)} and dtype {getattr(value, 'dtype', '?')}"
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{type(value).__name__} {text}"


def summarise(items, *, limit: int = _LISTED, sep: str = ", ") -> str:
    """The first ``limit`` items joined by ``sep``, then how many more: messages stay one short line.

    Examples
    --------
    >>> summarise([1, 2])
    '1, 2'
    >>> summarise(range(10))
    '0, 1, 2 and 7 more'
    """
    items = [str(i) for i in items]
    if len(items) <= limit:
        return sep.join(items)
    return f"{sep.join(items[:limit])} and {len(items) - limit} more"


def _is_complex(raw: np.ndarray) -> bool:
    if raw.dtype.kind == "c":
        return True
    if raw.dtype == object:
        return any(isinstance(v, (complex, np.complexfloating)) for v in raw.flat)
    return False


def _index(bad: np.ndarray):
    first = tuple(int(i) for i in bad[0])
    return first if len(first) != 1 else first[0]


def _digits(value: int) -> str:
    """``"31 digits"`` of an int; estimated past 3000 digits, where ``str`` is slow or refuses (4300)."""
    bits = abs(value).bit_length()
    if bits <= 10_000:
        return f"{len(str(abs(value)))} digits"
    return f"about {int(bits * 0.30102999566398120) + 1} digits"


def _check_huge_integers(raw: np.ndarray, name: str) -> None:
    """Python ints above MAX_MAGNITUDE in an object array, reported before float64 overflows on them."""
    for k, v in enumerate(raw.flat):
        if isinstance(v, (int, np.integer)) and not isinstance(v, bool) and abs(int(v)) > MAX_MAGNITUDE:
            where = np.unravel_index(k, raw.shape) if raw.ndim else ()
            index = f" at index {where[0] if len(where) == 1 else tuple(int(i) for i in where)}" if where \
                else ""
            raise ValueError(f"{name}: expected values of magnitude at most {MAX_MAGNITUDE:g} (larger ones "
                             f"overflow the solvers; rescale the data), got an integer of "
                             f"{_digits(int(v))}{index}")


def _check_range(arr: np.ndarray, name: str, raw: np.ndarray | None = None) -> None:
    """NaN, inf and magnitudes above MAX_MAGNITUDE, each reported with its first index and count.

    ``raw`` is the input before the cast: a string such as ``"1e400"`` that became inf is shown as written.
    """
    if arr.size == 0:
        return
    lo, hi = arr.min(), arr.max()  # two reductions; NaN propagates and fails the test below
    if -MAX_MAGNITUDE <= lo and hi <= MAX_MAGNITUDE:
        return
    finite = np.isfinite(arr)
    if not finite.all():
        bad = np.argwhere(~finite)
        kind = "NaN" if np.isnan(arr[tuple(bad[0])]) else "inf"
        if raw is not None and raw.dtype.kind in "USO" and raw.shape == arr.shape:
            written = str(raw[tuple(bad[0])]).strip()
            if written.lower().lstrip("+-") not in ("nan", "inf", "infinity"):
                kind = f"{written[:30]!r}, beyond float64's range,"
        raise ValueError(
            f"{name}: expected finite values, got {len(bad)} non-finite value(s) "
            f"({kind} first at index {_index(bad)})"
        )
    bad = np.argwhere(np.abs(arr) > MAX_MAGNITUDE)
    value = float(arr[tuple(bad[0])])
    raise ValueError(
        f"{name}: expected values of magnitude at most {MAX_MAGNITUDE:g} (larger ones overflow the "
        f"solvers; rescale the data), got {value!r} at index {_index(bad)} ({len(bad)} such value(s))"
    )


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
        If the input is complex or cannot be converted, has the wrong ndim,
        holds NaN or inf or a magnitude above :data:`MAX_MAGNITUDE`, or is too
        short.

    Examples
    --------
    >>> check_array([[0.0, 1.0], [2.0, 3.0]], name="Y").shape
    (2, 2)
    """
    try:
        raw = np.asarray(value)
        if _is_complex(raw):
            # Casting would drop the imaginary part with only a ComplexWarning.
            raise ValueError(f"{name}: expected real numbers, got complex values ({_describe(raw)})")
        if raw.dtype == object:
            _check_huge_integers(raw, name)  # a Python int beyond float64 raises OverflowError in the cast
        arr = raw.astype(np.float64, copy=False)
    except (TypeError, ValueError) as exc:
        if str(exc).startswith(f"{name}: "):
            raise
        raise ValueError(
            f"{name}: expected an array of real numbers, got {_describe(value)} "
            f"which cannot be converted to float ({' '.join(str(exc).split())[:200]})"
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
    _check_range(arr, name, raw)
    return arr


def check_time(t, *, name: str = "t", min_samples: int = 1, n_steps: int | None = None):
    """Check a time vector: 1-D, finite, within :data:`MAX_MAGNITUDE`, strictly increasing.

    Strictly increasing is checked on the differences as computed
    (``np.diff``), so stamps too close for float64 at their magnitude
    (``1e20`` and ``1e20 + 1``) count as repeated.

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


def _real_scalar(value, name: str, expected: str) -> float:
    """``value`` as a float, or ValueError: not a real number, or beyond float64."""
    if isinstance(value, (complex, np.complexfloating)):
        raise ValueError(f"{name}: expected a real number, got complex {value!r}")
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name}: expected {expected}, got {_describe(value)}")
    try:
        return float(value)
    except OverflowError:  # a Python int beyond float64
        raise ValueError(f"{name}: expected {expected} of magnitude at most {MAX_MAGNITUDE:g}, got an "
                         f"integer of {_digits(int(value))}") from None


#: Ids are signed 64-bit integers in every store (SQLite INTEGER, PostgreSQL BIGINT): no larger one exists.
_ID_RANGE = (-2 ** 63, 2 ** 63 - 1)


def check_id(value, *, name: str) -> int:
    """Check an integer id (a bool is not one) within the signed 64-bit range every store holds.

    Examples
    --------
    >>> check_id(3, name="demo_id")
    3
    >>> try:
    ...     check_id(10 ** 30, name="cluster")
    ... except ValueError as exc:
    ...     print(str(exc)[-39:])
    2**63 - 1], got an integer of 31 digits
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name}: expected an integer id, got {value!r}")
    number = int(value)
    if not _ID_RANGE[0] <= number <= _ID_RANGE[1]:
        raise ValueError(f"{name}: expected an integer id within the signed 64-bit range "
                         f"[-2**63, 2**63 - 1], got an integer of {_digits(number)}")
    return number


def check_positive(value, *, name: str, integer: bool = False, allow_zero: bool = False):
    """Check a scalar hyperparameter is a positive (optionally integer) number, at most MAX_MAGNITUDE.

    Examples
    --------
    >>> check_positive(3, name="window", integer=True)
    3
    """
    kind = "an integer" if integer else "a number"
    bound = ">= 0" if allow_zero else "> 0"
    number = _real_scalar(value, name, f"{kind} {bound}")
    if not np.isfinite(number) or number < 0 or (number == 0 and not allow_zero):
        raise ValueError(f"{name}: expected {kind} {bound}, got {value!r}")
    if integer and number != int(number):
        raise ValueError(f"{name}: expected an integer {bound}, got {value!r}")
    if number > MAX_MAGNITUDE:
        raise ValueError(f"{name}: expected {kind} {bound} and at most {MAX_MAGNITUDE:g} (larger ones "
                         f"overflow the solvers), got {number!r}")
    return int(value) if integer else number


def env_bound(variable: str, default: int, what: str, environ=None) -> int:
    """A bound a user may raise: the whole number > 0 in ``$variable``, else ``default``.

    ``what`` names the unit in the message (``"samples"``, ``"steps"``). ``environ`` defaults to
    ``os.environ``.

    Examples
    --------
    >>> env_bound("X", 10, "steps", {}), env_bound("X", 10, "steps", {"X": "20"})
    (10, 20)
    """
    environ = os.environ if environ is None else environ
    text = environ.get(variable, "").strip()
    if not text:
        return default
    try:
        value = int(text)
        if value <= 0:
            raise ValueError
    except ValueError:
        raise ValueError(f"{variable}: expected a whole number of {what} > 0, got {text[:40]!r}") from None
    return value


def check_fraction(value, *, name: str, low: float = 0.0, high: float = 1.0):
    """Check a scalar lies in the closed interval ``[low, high]``.

    Examples
    --------
    >>> check_fraction(0.2, name="threshold")
    0.2
    """
    number = _real_scalar(value, name, f"a number in [{low}, {high}]")
    if not np.isfinite(number) or not (low <= number <= high):
        raise ValueError(f"{name}: expected a number in [{low}, {high}], got {value!r}")
    return number


def check_finite_result(value, *, name: str):
    """Return ``value`` (an array or a number) if it is finite; else ValueError naming what produced it.

    Used on what a solver returns or stores, so a result that overflowed is
    never handed on or written.

    Examples
    --------
    >>> check_finite_result([1.0, 2.0], name="lte")
    [1.0, 2.0]
    >>> try:
    ...     check_finite_result([1.0, float("inf")], name="lte")
    ... except ValueError as exc:
    ...     print(str(exc)[:49])
    lte: produced 1 non-finite value(s) (inf first at
    """
    arr = np.asarray(value, dtype=float)
    finite = np.isfinite(arr)
    if finite.all():
        return value
    bad = np.argwhere(~finite)
    where = f" first at index {_index(bad)}" if arr.ndim else ""
    kind = "NaN" if np.isnan(arr[tuple(bad[0])]) else "inf"
    raise ValueError(f"{name}: produced {len(bad)} non-finite value(s) ({kind}{where}): the input's "
                     "magnitudes or time steps are beyond what it handles")


#: What numpy, scipy and Python raise on numerical trouble once warnings are errors.
_NUMERICAL = (FloatingPointError, ArithmeticError, RuntimeWarning, np.linalg.LinAlgError)


@contextmanager
def numerical_errors(step: str):
    """Run a solver with floating-point trouble turned into one ValueError naming ``step``.

    Inside, numpy raises on overflow, division by zero and invalid
    operations (``np.errstate``), and every ``RuntimeWarning`` (numpy's,
    ``ComplexWarning``, scipy's ``LinAlgWarning``) is an error; any of these,
    a Python ``OverflowError`` or a ``LinAlgError`` leaves as ``ValueError``
    with a one-line message. Other ``ValueError``s (the input checks) pass
    unchanged. Used at the public entry points, also as a decorator; code
    that expects infinities inside sets its own ``np.errstate``.

    Examples
    --------
    >>> import numpy as np
    >>> try:
    ...     with numerical_errors("scale"):
    ...         np.float64(1e300) * 1e300
    ... except ValueError as exc:
    ...     print(str(exc).split(";")[0])
    scale: the computation overflowed or became undefined (overflow encountered in scalar multiply)
    """
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        try:
            with np.errstate(over="raise", divide="raise", invalid="raise"):
                yield
        except _NUMERICAL as exc:
            detail = " ".join(str(exc).split())[:200] or type(exc).__name__
            raise ValueError(f"{step}: the computation overflowed or became undefined ({detail}); the "
                             "input's magnitudes or time steps are beyond what it handles") from None
