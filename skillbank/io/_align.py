"""Bringing streams recorded on their own clocks onto one time base, and reporting their gaps.

A recording (a ROS bag) holds each sensor on its own clock and rate. Every
stream is resampled onto one time base: continuous values linearly,
orientations (unit quaternions, scalar last) by spherical linear
interpolation (:func:`skillbank.core.slerp`, which also removes sign flips
between samples), discrete values (a command, an open/closed state) by
holding the last sample. Outside a stream's own time range its edge value is
held, as in :meth:`~skillbank.core.Demonstration.from_clocks`; the gap
report says how far that reaches.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterable
from typing import NamedTuple

import numpy as np

from ..core._rotations import slerp
from ..core._validation import check_positive
from ._errors import FormatError

__all__ = ["KINDS", "Source", "time_base", "resample_stream", "hold", "coverage", "cut_points",
           "check_split", "split_pieces", "align_sources"]

#: How a stream is brought onto the time base.
KINDS = ("linear", "slerp", "hold")

#: Gaps listed one by one in a report; the count says how many there were in all.
LISTED_GAPS = 5


#: Resampling at ``rate`` Hz creates at most this many samples unless the
#: environment variable :data:`MAX_SAMPLES_VARIABLE` allows more: 10^7 samples
#: are 2.8 hours at 1 kHz, and 80 MB per column (a bag's 20 columns of joints,
#: pose, wrench and gripper: 1.6 GB) before any work on them.
MAX_RESAMPLED = 10**7
MAX_SAMPLES_VARIABLE = "SKILLBANK_MAX_SAMPLES"


def _max_resampled() -> int:
    text = os.environ.get(MAX_SAMPLES_VARIABLE, "").strip()
    if not text:
        return MAX_RESAMPLED
    try:
        value = int(float(text))
        if value < 2 or value != float(text):
            raise ValueError
    except (ValueError, OverflowError):
        raise ValueError(f"{MAX_SAMPLES_VARIABLE}: expected a whole number of samples >= 2, "
                         f"got {text!r}") from None
    return value


def time_base(t_ref, rate=None) -> np.ndarray:
    """The common time base: the reference clock itself, or ``rate`` Hz across its span.

    The samples a rate creates (span x rate + 1) are counted before any is
    made: more than :data:`MAX_RESAMPLED` (10^7; ``SKILLBANK_MAX_SAMPLES``
    sets another bound) is an error naming the count.

    Examples
    --------
    >>> time_base([0.0, 0.013, 0.021, 0.03], rate=100).tolist()
    [0.0, 0.01, 0.02, 0.03]
    """
    t_ref = np.asarray(t_ref, dtype=float)
    if rate is None:
        return t_ref
    rate = check_positive(rate, name="rate")
    span = float(t_ref[-1] - t_ref[0])
    # A hair of slack so that a span of whole periods keeps its last sample.
    count = np.floor(span * rate + 1e-9) + 1
    bound = _max_resampled()
    if count > bound:
        raise ValueError(f"rate: {rate:g} Hz over the recording's {span:g} s would create {count:.3g} "
                         f"samples, more than the bound of {bound:g}; give a lower rate, or set "
                         f"{MAX_SAMPLES_VARIABLE} to a larger count of samples")
    return t_ref[0] + np.arange(int(count)) / rate


def hold(t_k, Y_k, t) -> np.ndarray:
    """Zero-order hold: at each ``t``, the last sample at or before it (the first before the start).

    Examples
    --------
    >>> hold([0.0, 1.0], [[5.0], [7.0]], [-1.0, 0.5, 1.0, 3.0]).ravel().tolist()
    [5.0, 5.0, 7.0, 7.0]
    """
    Y_k = np.asarray(Y_k, dtype=float)
    idx = np.searchsorted(np.asarray(t_k, dtype=float), t, side="right") - 1
    return Y_k[np.clip(idx, 0, Y_k.shape[0] - 1)]


def _linear(t_k, Y_k, t) -> np.ndarray:
    return np.column_stack([np.interp(t, t_k, col) for col in Y_k.T])


def resample_stream(t_k, Y_k, t, kind: str = "linear") -> np.ndarray:
    """Bring one stream ``(t_k, Y_k)`` onto the time base ``t`` by ``kind`` (see :data:`KINDS`).

    Examples
    --------
    >>> resample_stream([0.0, 2.0], [[0.0], [4.0]], [1.0]).ravel().tolist()
    [2.0]
    """
    if kind not in KINDS:
        raise ValueError(f"kind: expected one of {list(KINDS)}, got {kind!r}")
    Y_k = np.asarray(Y_k, dtype=float)
    if Y_k.ndim == 1:
        Y_k = Y_k[:, None]
    t_k = np.asarray(t_k, dtype=float)
    if t_k.shape == np.shape(t) and np.array_equal(t_k, t):
        return Y_k
    if kind == "hold":
        return hold(t_k, Y_k, t)
    if kind == "slerp":
        return slerp(t_k, Y_k, t)
    return _linear(t_k, Y_k, t)


def coverage(t_k, start: float, end: float, max_gap: float) -> dict:
    """How a stream's samples ``t_k`` cover the span ``[start, end]`` of a time base.

    The intervals without a sample are those between consecutive samples,
    clipped to the span; a stream that begins late or ends early leaves an
    interval at the start or the end. Times in the report are relative to
    ``start``.

    Returns
    -------
    dict
        ``messages`` (samples inside the span), ``rate_hz`` (their mean rate,
        ``None`` with fewer than two), ``start`` and ``end`` (the first and
        last sample inside, ``None`` when there is none), ``max_gap`` (the
        longest interval without a sample), ``n_gaps`` (intervals longer than
        ``max_gap``) and ``gaps`` (the first :data:`LISTED_GAPS` of them as
        ``[from, to]`` pairs, clipped to the span).

    Examples
    --------
    >>> r = coverage([0.0, 0.1, 0.2, 1.0, 1.1], 0.0, 1.1, max_gap=0.5)
    >>> r["n_gaps"], r["gaps"], r["max_gap"]
    (1, [[0.2, 1.0]], 0.8)
    """
    t_k = np.asarray(t_k, dtype=float)
    i0 = int(np.searchsorted(t_k, start, side="left"))
    i1 = int(np.searchsorted(t_k, end, side="right"))
    inside = t_k[i0:i1]
    before = t_k[i0 - 1] if i0 > 0 else start
    after = t_k[i1] if i1 < t_k.shape[0] else end
    points = np.clip(np.concatenate([[before], inside, [after]]), start, end)
    steps = np.diff(points)
    long = np.flatnonzero(steps > max_gap)
    n = int(inside.shape[0])
    span = float(inside[-1] - inside[0]) if n > 1 else 0.0
    return {
        "messages": n,
        "rate_hz": round((n - 1) / span, 6) if span > 0 else None,
        "start": round(float(inside[0] - start), 9) if n else None,
        "end": round(float(inside[-1] - start), 9) if n else None,
        "max_gap": round(float(steps.max()), 9),
        "n_gaps": int(long.size),
        "gaps": [[round(float(points[i] - start), 9), round(float(points[i + 1] - start), 9)]
                 for i in long[:LISTED_GAPS]],
    }


def cut_points(t, max_gap: float) -> list[tuple[float, float]]:
    """The runs of the clock ``t`` between steps longer than ``max_gap``, as ``(first, last)`` times.

    Examples
    --------
    >>> cut_points([0.0, 0.1, 0.2, 5.0, 5.1], max_gap=1.0)
    [(0.0, 0.2), (5.0, 5.1)]
    """
    t = np.asarray(t, dtype=float)
    breaks = np.flatnonzero(np.diff(t) > max_gap)
    firsts = np.concatenate([[0], breaks + 1])
    lasts = np.concatenate([breaks, [t.shape[0] - 1]])
    return [(float(t[a]), float(t[b])) for a, b in zip(firsts, lasts, strict=True)]


def check_split(split):
    """Validate a ``split`` option: None, ``"gaps"``, a marker topic ``"/name"``, or ``(start, stop)`` pairs.

    Pairs may also be written ``"start:stop,start:stop"`` (the command line's form).

    Examples
    --------
    >>> check_split([(0, 1.5), (2, 3)])
    [(0.0, 1.5), (2.0, 3.0)]
    >>> check_split("0:1.5, 2:3")
    [(0.0, 1.5), (2.0, 3.0)]
    """
    if split is None or split == "gaps" or (isinstance(split, str) and split.startswith("/")):
        return split
    message = ("split: expected None, 'gaps', a marker topic like '/marker', or (start, stop) pairs in "
               f"seconds with start < stop (or 'start:stop,...'), got {split!r}")
    if isinstance(split, str):
        split = [part.split(":") for part in split.split(",")]
    if not isinstance(split, Iterable):
        raise ValueError(message)
    pairs = []
    for pair in split:
        try:
            lo, hi = (float(v) for v in pair)  # a pair of anything else than two numbers fails here
        except (TypeError, ValueError):
            raise ValueError(message) from None
        if not lo < hi:
            raise ValueError(message)
        pairs.append((lo, hi))
    if not pairs:
        raise ValueError(message)
    return pairs


def split_pieces(split, t_ref, marker=None, max_gap: float = np.inf) -> list[tuple[float, float]]:
    """Half-open clock ranges ``[lo, hi)``, one per demonstration, for a validated ``split``.

    ``"gaps"`` cuts the reference clock ``t_ref`` where it pauses for more
    than ``max_gap``. A marker is ``(times, values)``: with boolean values,
    True opens a demonstration and False closes it; with ``values=None``
    each marker opens one that lasts until the next. ``(start, stop)`` pairs
    count from ``t_ref[0]``.

    Examples
    --------
    >>> split_pieces("/m", [0.0, 9.0], marker=(np.array([1.0, 2.0, 3.0]), np.array([True, False, True])))
    [(1.0, 2.0), (3.0, inf)]
    """
    end = float("inf")
    if split is None:
        return [(-end, end)]
    if split == "gaps":
        runs = cut_points(t_ref, max_gap)
        return [(a, runs[i + 1][0] if i + 1 < len(runs) else end) for i, (a, _) in enumerate(runs)]
    if isinstance(split, str):
        times, values = marker
        times = [float(t) for t in times]
        if values is None:
            return [(a, times[i + 1] if i + 1 < len(times) else end) for i, a in enumerate(times)]
        pieces, opened = [], None
        for t, v in zip(times, values, strict=True):
            if v and opened is None:
                opened = t
            elif not v and opened is not None:
                pieces.append((opened, t))
                opened = None
        return pieces + ([(opened, end)] if opened is not None else [])
    return [(float(t_ref[0]) + lo, float(t_ref[0]) + hi) for lo, hi in split]


class Source(NamedTuple):
    """One recorded source (a topic) on its own clock, and the streams it makes.

    ``parts`` maps each stream to ``(first column, last column + 1, kind)``;
    ``checked`` says whether a gap longer than the limit is an error (or a
    warning) rather than only reported; ``info`` is copied into its report.
    """

    t: np.ndarray
    rows: np.ndarray
    parts: dict
    checked: bool = True
    info: dict | None = None


def align_sources(path, base, sources: dict, *, max_gap: float, on_gap: str = "error", where: str = ""):
    """Bring every source onto the time base ``base``: ``(streams, stream -> source, report)``.

    Each source's coverage of the base (see :func:`coverage`) goes into the
    report under its name; a checked source with a gap longer than
    ``max_gap`` is a :class:`FormatError` (``on_gap="error"``) or a
    ``UserWarning`` (``"warn"``).

    Examples
    --------
    >>> src = Source(np.array([0.0, 1.0]), np.array([[0.0], [2.0]]), {"x": (0, 1, "linear")})
    >>> streams, made, report = align_sources("a.bag", np.array([0.0, 0.5, 1.0]), {"/x": src}, max_gap=2)
    >>> streams["x"].ravel().tolist(), made, report["/x"]["rate_hz"]
    ([0.0, 1.0, 2.0], {'x': '/x'}, 1.0)
    """
    streams, made, report = {}, {}, {}
    for name, src in sources.items():
        cov = coverage(src.t, base[0], base[-1], max_gap)
        if src.checked and cov["n_gaps"]:
            first = cov["gaps"][0]
            text = (f"{where}{name!r} has {cov['n_gaps']} gap(s) longer than max_gap={max_gap:g} s, the "
                    f"first from {first[0]:.3f} s to {first[1]:.3f} s (longest {cov['max_gap']:.3f} s); "
                    "raise max_gap, read with on_gap='warn', or split='gaps'")
            if on_gap == "error":
                raise FormatError(path, text)
            warnings.warn(f"{path}: {text}", UserWarning, stacklevel=3)
        report[name] = {**(src.info or {}), "gaps_checked": src.checked, **cov}
        for stream, (lo, hi, kind) in src.parts.items():
            try:
                streams[stream] = resample_stream(src.t, src.rows[:, lo:hi], base, kind)
            except ValueError as exc:  # e.g. a zero quaternion: name the source, not the helper's argument
                raise FormatError(path, f"{where}{name!r}, stream {stream!r}: {exc}") from None
            made[stream] = name
    return streams, made, report
