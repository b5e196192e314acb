"""Segmentation result objects."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import Demonstration

__all__ = ["StreamSegmentation", "SegmentationResult"]

#: A stream whose evidence at a keypoint is below this did not support it.
REPORTED_EVIDENCE = 0.05


@dataclass
class StreamSegmentation:
    """What segmentation found on one data stream.

    Attributes
    ----------
    name : str
    params : dict
        Window, min_size, threshold and grace in samples, as used.
    jerk : ndarray of shape (n_steps,)
        Jerk norm per sample (relative or absolute, see ``params["scale"]``).
    profile : ndarray of shape (n_steps,)
        Normalised sliding-window mean of ``jerk``, in [0, 1].
    changepoints : ndarray of int
        Sample indices where a new segment starts.
    strength : ndarray of float
        Prominence of each changepoint's jerk event.
    probability : ndarray of shape (n_steps,)
        The stream's keypoint curve: a Gaussian per changepoint, of height its
        confidence with ``combine="evidence"`` (the default), over the floor
        with ``"product"``.
    jerk_step : int
        Stride, in samples, of the differences the jerk was taken over: 1,
        unless the values' round-off (few significant digits on a fine grid)
        would have swamped the jerk (see :func:`~skillbank.segmentation.jerk_profile`).
    kind : str
        ``"motion"``, ``"contact"`` or ``"discrete"``: what the stream's
        changepoints are (stops and turns, contact steps, switches).
    floor : float
        The floor under :attr:`probability` (the product rule's; 0 for evidence).
    """

    name: str
    params: dict
    jerk: np.ndarray
    profile: np.ndarray
    changepoints: np.ndarray
    strength: np.ndarray
    probability: np.ndarray
    jerk_step: int = 1
    kind: str = "motion"
    floor: float = 0.0

    def evidence(self, index) -> np.ndarray:
        """Evidence of a boundary at sample(s) ``index``: the curve above its floor, in [0, 1]."""
        return np.clip(self.probability[index] - self.floor, 0.0, 1.0)


@dataclass
class SegmentationResult:
    """The outcome of segmenting one demonstration.

    Attributes
    ----------
    demonstration : Demonstration
        The segmented input.
    streams : dict of str to StreamSegmentation
    probability : ndarray of shape (n_steps,)
        The combined keypoint probability: with ``combine="evidence"`` (the
        default) the noisy-OR of the kinds' averaged confidences; with
        ``"product"`` the product of the stream curves.
    support : ndarray of shape (n_steps,)
        How many streams agree at each sample.
    keypoints : ndarray of int
        Interior cut indices; there are ``n_segments - 1`` of them.
    mode : str
        ``"deterministic"`` or ``"sampling"``.
    params : dict
        Each stream's settings, by stream name.
    combine : str
        ``"product"`` (the paper's rule) or ``"evidence"``.
    set_aside : dict of str to str
        The streams that carried no information (constant, or constant to
        within their round-off), each with the reason: they took no part in
        the keypoints (their entry in :attr:`streams` has no events).
    constant_columns : dict of str to list of int
        Per stream, the constant columns left out of an otherwise informative stream.
    phases : list of Phase
        The demonstration's phases where they cut it (:func:`~skillbank.segmentation.demonstration_phases`),
        else empty.
    """

    demonstration: Demonstration
    streams: dict
    probability: np.ndarray
    support: np.ndarray
    keypoints: np.ndarray
    mode: str
    params: dict = field(default_factory=dict)
    combine: str = "product"
    set_aside: dict = field(default_factory=dict)
    constant_columns: dict = field(default_factory=dict)
    phases: list = field(default_factory=list)

    @property
    def changepoints(self) -> dict:
        """Each stream's changepoints, by stream name."""
        return {k: v.changepoints for k, v in self.streams.items()}

    @property
    def keypoint_times(self) -> np.ndarray:
        """Keypoints as times in seconds on the demonstration's clock."""
        return self.demonstration.t[self.keypoints]

    @property
    def n_segments(self) -> int:
        """Number of segments (keypoints + 1)."""
        return int(self.keypoints.size + 1)

    @property
    def bounds(self) -> list[tuple[int, int]]:
        """``(start, stop)`` sample range of each segment (stop exclusive)."""
        edges = np.concatenate(([0], self.keypoints, [self.demonstration.n_steps])).astype(int)
        return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:], strict=False)]

    @property
    def labels(self) -> np.ndarray:
        """Segment index of every sample, shape (n_steps,)."""
        labels = np.zeros(self.demonstration.n_steps, dtype=int)
        labels[self.keypoints] = 1
        return np.cumsum(labels)

    @property
    def segments(self) -> list[Demonstration]:
        """The segments as Demonstrations, with ``segment`` in their metadata."""
        out = []
        for i, (a, b) in enumerate(self.bounds):
            seg = self.demonstration.slice(a, b)
            seg.metadata["segment"] = i
            out.append(seg)
        return out

    @property
    def keypoint_support(self) -> list[dict]:
        """Per keypoint, each stream that supported it and its evidence there (at least 0.05)."""
        out = []
        for k in self.keypoints:
            ev = {name: float(s.evidence(int(k))) for name, s in self.streams.items()}
            out.append({name: round(e, 3) for name, e in ev.items() if e >= REPORTED_EVIDENCE})
        return out

    def to_dict(self) -> dict:
        """The JSON form printed by ``skillbank segment --json``."""
        return {
            # the combined probability at each keypoint: the product's share (product), or the
            # chance of a boundary (evidence); and which streams saw it, how strongly
            "keypoint_probability": [round(float(self.probability[k]), 6) for k in self.keypoints],
            "keypoint_support": self.keypoint_support,
            "combine": self.combine,
            "keypoints": [int(k) for k in self.keypoints],
            "keypoint_times": [float(x) for x in self.keypoint_times],
            "changepoints": {k: [int(c) for c in v] for k, v in self.changepoints.items()},
            "n_segments": self.n_segments,
            # > 1 where the stream's round-off made the jerk be taken over a stride of samples
            "jerk_step": {k: int(v.jerk_step) for k, v in self.streams.items()},
            # streams that carried no information, with the reason, and constant columns left out
            "set_aside": dict(self.set_aside),
            "constant_columns": {k: [int(c) for c in v] for k, v in self.constant_columns.items()},
            # the phases the cut follows (a reach, a carry, a retreat, per object), where there are any
            "phases": [p.to_dict() for p in self.phases],
        }
