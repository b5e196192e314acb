"""The data model: one demonstration with named, time-aligned streams."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ._rotations import check_quaternions, continuous_quaternions, slerp
from ._validation import check_array, check_time

__all__ = ["Demonstration", "ORIENTATION"]

#: The stream that holds the end effector's orientation: unit quaternions, scalar-last (x, y, z, w).
ORIENTATION = "orientation"
# |q|^2 of a quaternion normalised in float64 is within a few units of round-off of 1
_UNIT_ROUNDOFF = 8 * np.finfo(float).eps


class Demonstration:
    """A demonstration: a time base plus named data streams on that base.

    Parameters
    ----------
    t : array-like of shape (n_steps,)
        Time in seconds, strictly increasing.
    streams : mapping of str to array-like of shape (n_steps, n_dims)
        Named data streams. A 1-D stream is stored as one column. The
        ``"orientation"`` stream holds unit quaternions, scalar-last
        ``(x, y, z, w)`` as scipy and ROS (readers of scalar-first files
        convert): each must have a norm within 0.01 of 1 (it is then
        renormalised), and signs are flipped where needed (``q`` and ``-q``
        are the same rotation) so that the stream is continuous.
    metadata : mapping, optional
        Free metadata (``source``, ``label``, ``user``, ...).

    Attributes
    ----------
    t : ndarray of shape (n_steps,)
    streams : dict of str to ndarray of shape (n_steps, n_dims)
    metadata : dict

    Examples
    --------
    >>> import numpy as np
    >>> demo = Demonstration(np.linspace(0, 1, 5), {"position": np.zeros((5, 2))})
    >>> demo[1:3].n_steps
    2
    >>> demo["position"].shape
    (5, 2)
    """

    def __init__(self, t, streams: Mapping | None = None, metadata: Mapping | None = None):
        self.t = check_time(t, name="t", min_samples=1)
        streams = {} if streams is None else streams
        if not isinstance(streams, Mapping):
            raise ValueError(
                f"streams: expected a mapping of stream name to array, got {type(streams).__name__}"
            )
        n = self.t.shape[0]
        self.streams: dict[str, np.ndarray] = {}
        for key, value in streams.items():
            if not isinstance(key, str) or not key:
                raise ValueError(f"streams: expected non-empty string names, got {key!r}")
            arr = check_array(value, name=f"streams[{key!r}]", ndim=(1, 2), as_2d=True)
            if arr.shape[0] != n:
                raise ValueError(
                    f"streams[{key!r}]: expected {n} samples to match t, got {arr.shape[0]}"
                )
            if key == ORIENTATION:
                # unit norm and no sign jumps: every interpolation and difference downstream relies on it
                unit = check_quaternions(arr, name=f"streams[{key!r}]")
                # samples already of norm 1 to round-off keep their bits: reading a stored stream back
                # gives the same numbers (and the same content hash), however often it is checked
                off = np.abs(np.einsum("ij,ij->i", arr, arr) - 1.0) > _UNIT_ROUNDOFF
                arr = continuous_quaternions(np.where(off[:, None], unit, arr))
            self.streams[key] = arr
        self.metadata: dict = dict(metadata or {})

    @classmethod
    def from_array(cls, Y, t=None, *, name: str = "position", dt: float = 1.0, metadata=None):
        """Build a one-stream demonstration from an array.

        Parameters
        ----------
        Y : array-like of shape (n_steps, n_dims)
        t : array-like of shape (n_steps,), optional
            Defaults to ``dt * arange(n_steps)``.
        name : str, default="position"
        dt : float, default=1.0
            Sample period used when ``t`` is not given.
        metadata : mapping, optional

        Examples
        --------
        >>> Demonstration.from_array([[0, 0], [1, 1], [2, 0]]).stream_names
        ['position']
        """
        arr = check_array(Y, name="Y", ndim=(1, 2), as_2d=True)
        if t is None:
            t = dt * np.arange(arr.shape[0], dtype=float)
        return cls(t, {name: arr}, metadata)

    @classmethod
    def from_clocks(cls, clocked: Mapping, *, reference: str | None = None, metadata=None):
        """Put streams recorded on different clocks onto one time base.

        Each stream is linearly interpolated onto the reference stream's clock
        (the ``"orientation"`` stream by SLERP); outside a stream's own time
        range its edge value is held.

        Parameters
        ----------
        clocked : mapping of str to (t_k, Y_k)
            Each stream with its own strictly increasing clock.
        reference : str, optional
            The stream whose clock becomes the time base (default: the first).
        metadata : mapping, optional

        Examples
        --------
        >>> demo = Demonstration.from_clocks(
        ...     {"a": ([0.0, 1.0, 2.0], [0.0, 1.0, 2.0]), "b": ([0.5, 1.5], [5.0, 7.0])})
        >>> demo["b"].ravel().tolist()
        [5.0, 6.0, 7.0]
        """
        if not clocked:
            raise ValueError("clocked: expected at least one stream, got none")
        names = list(clocked)
        reference = names[0] if reference is None else reference
        if reference not in clocked:
            raise ValueError(f"reference: expected one of {names}, got {reference!r}")
        parsed = {}
        for key, pair in clocked.items():
            if not isinstance(pair, (tuple, list)) or len(pair) != 2:
                raise ValueError(f"clocked[{key!r}]: expected a (t, Y) pair, got {type(pair).__name__}")
            tk = check_time(pair[0], name=f"clocked[{key!r}] time")
            yk = check_array(pair[1], name=f"clocked[{key!r}] data", ndim=(1, 2), as_2d=True)
            if yk.shape[0] != tk.shape[0]:
                raise ValueError(
                    f"clocked[{key!r}]: expected data with {tk.shape[0]} samples to match its "
                    f"clock, got {yk.shape[0]}"
                )
            parsed[key] = (tk, yk)
        t_ref = parsed[reference][0]
        streams = {}
        for key, (tk, yk) in parsed.items():
            if key == reference or (tk.shape == t_ref.shape and np.array_equal(tk, t_ref)):
                streams[key] = yk
            elif key == ORIENTATION:
                # rotations interpolate along the great circle (SLERP), not component by component
                streams[key] = slerp(tk, check_quaternions(yk, name=f"clocked[{key!r}] data"), t_ref)
            else:
                streams[key] = np.column_stack([np.interp(t_ref, tk, col) for col in yk.T])
        return cls(t_ref, streams, metadata)

    @property
    def n_steps(self) -> int:
        """Number of samples."""
        return int(self.t.shape[0])

    @property
    def duration(self) -> float:
        """Time span in seconds."""
        return float(self.t[-1] - self.t[0])

    @property
    def stream_names(self) -> list[str]:
        """Names of the streams, in insertion order."""
        return list(self.streams)

    def __len__(self) -> int:
        return self.n_steps

    def __contains__(self, name) -> bool:
        return name in self.streams

    def __getitem__(self, key):
        """``demo["name"]`` returns a stream; ``demo[a:b]`` a sliced Demonstration."""
        if isinstance(key, str):
            if key not in self.streams:
                raise KeyError(f"no stream {key!r}; streams are {self.stream_names}")
            return self.streams[key]
        if isinstance(key, slice):
            return self.slice(key.start, key.stop, key.step)
        raise TypeError(f"index with a stream name or a slice, got {type(key).__name__}")

    def slice(self, start: int | None = None, stop: int | None = None, step: int | None = None):
        """Return the samples ``start:stop:step`` as a new Demonstration.

        The metadata is copied and records the sample range in ``"range"``
        relative to the original ``"range"`` when there is one.

        Examples
        --------
        >>> import numpy as np
        >>> Demonstration.from_array(np.arange(10.0)).slice(2, 5).metadata["range"]
        [2, 5]
        """
        sl = slice(start, stop, step)
        lo, hi, st = sl.indices(self.n_steps)
        if len(range(lo, hi, st)) == 0:
            raise ValueError(
                f"slice: expected a non-empty sample range in [0, {self.n_steps}), "
                f"got {start}:{stop}"
            )
        meta = dict(self.metadata)
        offset = meta.get("range", [0, self.n_steps])[0]
        meta["range"] = [int(offset + lo), int(offset + min(hi, self.n_steps))]
        return Demonstration(
            self.t[sl], {k: v[sl] for k, v in self.streams.items()}, meta
        )

    def select(self, names) -> Demonstration:
        """Return a Demonstration holding only the named streams."""
        names = [names] if isinstance(names, str) else list(names)
        missing = [n for n in names if n not in self.streams]
        if missing:
            raise ValueError(
                f"streams: expected names among {self.stream_names}, got unknown {missing}"
            )
        return Demonstration(self.t, {n: self.streams[n] for n in names}, self.metadata)

    def copy(self) -> Demonstration:
        """Deep copy."""
        return Demonstration(
            self.t.copy(), {k: v.copy() for k, v in self.streams.items()}, dict(self.metadata)
        )

    def __repr__(self) -> str:
        parts = ", ".join(f"{k}: {v.shape[1]}-D" for k, v in self.streams.items())
        label = self.metadata.get("label")
        extra = f", label={label!r}" if label is not None else ""
        return f"Demonstration(n_steps={self.n_steps}, duration={self.duration:.3g} s, {{{parts}}}{extra})"
