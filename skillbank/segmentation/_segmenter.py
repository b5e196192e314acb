"""The probabilistic multimodal segmenter."""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from ..core import Demonstration
from ..core._params import Params
from ..core._validation import check_fraction, check_positive, numerical_errors
from ._changepoints import detect_changepoints, refine_to_jerk_centre
from ._constant import constant_columns, why_constant
from ._events import contact_events, discrete_events, rest_speed, stream_kind
from ._gate import _gate_changepoints
from ._keypoints import (
    changepoint_probability,
    combine_evidence,
    combine_probabilities,
    evidence_curve,
    keypoints_deterministic,
    keypoints_sampling,
)
from ._motion import merge_motionless, motion_evidence, moves, turning
from ._phases import demonstration_phases, phase_bounds
from ._profile import _stream_jerk, speed_norm
from ._result import SegmentationResult, StreamSegmentation
from ._timescale import motion_time_scale

__all__ = ["MultimodalSegmenter", "segment", "to_samples"]

_STREAM_KEYS = ("window", "min_size", "threshold", "grace", "scale", "normalize", "stop_ratio", "min_turn")
_SECONDS = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*s\s*$")

#: ``window="auto"`` is this fraction of the demonstration's length (at most the motion's
#: time scale, :func:`_auto_window`). With ``min_size`` one window (the default rule,
#: ``combine="evidence"``) a demonstration then holds at most 25 segments, with two (the
#: product rule's) at most 12, and each of a handful of primitives spans several windows.
AUTO_WINDOW_FRACTION = 0.04

#: ... and at least this many samples: wider than the jerk of a single kink
#: (five samples, from three centred differences), so that the window of a
#: short demonstration still averages the noise around an event, not only the event.
MIN_AUTO_WINDOW = 8

#: ``min_size="auto"`` is this many windows under the product rule (``combine="product"``): the
#: windowed mean smears each jerk event over one window, so two events less than two windows apart
#: leave hardly a valley between them to tell them apart. The default rule (``"evidence"``) reads
#: rests and switches, not jerk peaks, and uses one window.
MIN_SIZE_WINDOWS = 2

#: The third derivative needs at least four samples (:func:`jerk` refuses fewer).
MIN_SAMPLES = 4

#: A stream needs room for this many minimum segments, i.e. for one cut.
MIN_SEGMENTS = 2

#: The jerk's centre of mass is taken within ``window // REFINE_DIVISOR`` of a
#: changepoint: wide enough to hold the event that the profile placed a sample
#: or two off, and narrow next to a ``min_size`` of one or two windows
#: between changepoints, so a neighbour's jerk stays out.
REFINE_DIVISOR = 4

#: ... and at least this many samples, a kink's jerk either side of it.
MIN_REFINE_HALF_WIDTH = 2

#: Each changepoint's Gaussian has sigma = this fraction of the window: the
#: window smears an event over itself, so a changepoint is placed to within
#: about half a window, and two streams that saw the same event still agree.
SIGMA_PER_WINDOW = 0.5

#: By default, a deterministic keypoint needs this fraction of the streams
#: (and at least one) to agree: with two streams either may place a keypoint
#: the other has no event at, with four two must agree.
DEFAULT_SUPPORT_FRACTION = 0.5

#: A keypoint at a single stream's Gaussian peak scores 1 on the support
#: scale; allow for the small loss where two streams' peaks are a little apart.
SUPPORT_SLACK = 0.25

#: With ``combine="evidence"``, a keypoint is a mode of the combined
#: probability where a boundary is more likely than not.
KEYPOINT_PROBABILITY = 0.5

COMBINES = ("evidence", "product")

#: ``min_turn=None``: no change of direction makes a boundary without a stop
#: (a turn is at most 180 degrees).
NO_TURN = 181.0

#: ``mode="sampling"`` draws at most this many samples per round: the draws
#: are sorted and grouped, so ten times the default's 20 000 is still quick.
MAX_DRAWS = 10**6

#: With ``combine="evidence"``, events of lower confidence are left out: a
#: tenth is a pen slowing to a sixth of its speed, or sensor noise at rest.
MIN_CONFIDENCE = 0.1


def to_samples(value, t: np.ndarray, *, name: str, allow_zero: bool = False) -> int:
    """Convert a size given in samples (int) or seconds (``"0.1s"``) to samples.

    Seconds are converted with the median sample period, so uneven sampling
    does not bias the conversion. A size must be positive (``"0s"`` is refused
    like ``0``) unless ``allow_zero``; a positive number of seconds is at
    least one sample.

    Examples
    --------
    >>> to_samples("0.5s", np.linspace(0, 1, 11), name="window")
    5
    >>> to_samples(8, np.linspace(0, 1, 11), name="window")
    8
    """
    if isinstance(value, str):
        match = _SECONDS.match(value)
        if not match:
            raise ValueError(f"{name}: expected an integer number of samples or seconds like '0.1s', "
                             f"got {value!r}")
        seconds = float(match.group(1))
        if seconds == 0.0:
            if allow_zero:
                return 0
            raise ValueError(f"{name}: expected seconds > 0 like '0.1s', got {value!r}")
        dt = float(np.median(np.diff(t))) if t.shape[0] > 1 else 1.0
        return max(1, int(round(seconds / dt)))
    return check_positive(value, name=name, integer=True, allow_zero=allow_zero)


class MultimodalSegmenter(Params):
    """Probabilistic multimodal segmentation of a demonstration into primitives.

    Each stream is segmented on its own: jerk (third time derivative, over a
    stride of samples where the values' round-off would swamp it; see
    :func:`~skillbank.segmentation.jerk_profile`) → norm
    over the dimensions → sliding-window mean → normalisation → changepoints
    at the onset of every jerk event whose prominence reaches ``threshold`` →
    the stop-or-turn gate, which keeps the events where the motion stops or
    turns (``stop_ratio``, ``min_turn``).
    By default (``combine="evidence"``) each stream is then read by its kind
    and is a witness of the boundaries it can see: its confidences, capped at
    0.9, are averaged over the streams of one kind and the kinds combined by
    noisy-OR; a keypoint is a mode of that probability above one half. The
    paper's rule (``combine="product"``) makes each changepoint a Gaussian with
    σ = window / 2 over a floor, multiplies the per-stream curves and takes the
    keypoints from the product.

    It follows scikit-learn's estimator contract: the hyperparameters are
    stored unchanged and checked by :meth:`fit`, so that ``get_params``,
    ``set_params`` and :func:`sklearn.base.clone` work (through
    :class:`skillbank.core._params.Params`, without importing scikit-learn).

    Parameters
    ----------
    window : int or str, default="auto"
        Sliding-window width, in samples or seconds (``"0.1s"``). ``"auto"``
        uses 4 % of the demonstration's length, but never more than its motion's
        time scale (:func:`~skillbank.segmentation.motion_time_scale`, the
        speed's correlation time), and at least 8 samples: a demonstration of a
        few movements gets 4 %, a long recording a window set by its movements,
        so the cost per sample and the cuts per minute do not grow with it.
    min_size : int or str, default="auto"
        Minimum segment length; ``"auto"`` uses 1 × window with
        ``combine="evidence"`` (the default) and 2 × window with ``"product"``.
    threshold : float, default=0.4
        Minimum prominence of a jerk event on the normalised profile, in (0, 1].
    grace : int or str, default="auto"
        Samples ignored at each end of a stream (start-up transients and the
        edge effects of differentiating); ``"auto"`` uses the window.
    scale : {"relative", "absolute"}, default="relative"
        ``"absolute"`` is the paper's jerk; ``"relative"`` divides it by the
        local speed, making streams of any unit comparable.
    normalize : {"robust", "max"}, default="robust"
        ``"max"`` is the paper's; ``"robust"`` the median of the five highest peaks.
    stop_ratio : float in [0, 1] or None, default=0.5
        The stop-or-turn gate (:func:`gate_changepoints`): a jerk event is a
        boundary only where the speed drops below this fraction of the peak
        speed of the movements either side (it is then moved to the slowest
        sample of a brief stop), or where the motion turns by ``min_turn``.
        This removes the events that jerk alone finds in the middle of a
        smooth movement. ``None`` keeps every event, as the paper does.
    min_turn : float in [0, 180] or None, default=45.0
        Change of direction, in degrees, over one window either side of an
        event, that makes it a boundary without a stop; ``None``: only stops do.
    combine : {"product", "evidence"}, default="evidence"
        ``"product"`` is the paper's rule: every stream's jerk changepoints
        become Gaussians over a floor, multiplied, and keypoints are where
        enough streams agree. ``"evidence"`` reads each stream by its kind
        (``stream_kinds``): motion streams give rests between movements
        (confidence from how fully the motion stops) and the gate's turns,
        contact streams (force, torque) steps and impacts, discrete streams
        (a gripper) switches; streams of one kind are averaged and the kinds
        combined by noisy-OR, so one confident kind carries a keypoint; a
        keypoint is a mode of that probability above one half.
    stream_kinds : mapping, optional
        Kind (``"motion"``, ``"contact"``, ``"discrete"``) per stream name,
        for ``combine="evidence"``; by default force, torque and wrench are
        contact, gripper is discrete, anything else motion.
    stream_params : mapping, optional
        Per-stream overrides, e.g. ``{"force": {"threshold": 0.3}}``.
    mode : {"deterministic", "sampling"}, default="deterministic"
        ``"deterministic"`` takes the modes of the combined curve where at
        least ``min_support`` streams agree; ``"sampling"`` is the paper's
        procedure, reproducible with ``random_state``.
    min_support : float, optional
        Streams that must agree on a deterministic keypoint; default half of
        the streams, at least 1.
    n_samples, min_hits : int, default=20, 3
        Draws per round, and draws a keypoint needs, in ``"sampling"`` mode.
    floor : float, default=0.05
        Baseline of each stream's curve, so no stream can veto the others.
    random_state : int, Generator or None
        Seed for ``"sampling"`` mode.
    phases : bool, default=True
        Where the demonstration records the tool's position, one gripper and the poses of objects,
        cut it at the phases its objects define (:func:`~skillbank.segmentation.demonstration_phases`:
        a reach for an object, its carry from the grasp to the release, the retreat), and not again
        inside a phase at the motion's pauses: a person's halting approach to a cube is one reach,
        not four primitives. ``False``, or a demonstration without them, is cut by the streams alone.

    Attributes
    ----------
    result_ : SegmentationResult
        Set by :meth:`fit`.
    phases_ : list of Phase
        The phases the cut follows (empty when the streams alone cut it).
    set_aside_ : dict of str to str
        The streams set aside because they carry no information (every column
        constant, or constant to within its round-off: a force sensor reading 0
        throughout), each with the reason. They take no part in the keypoints:
        the other streams are cut exactly as they would be without them. When
        every stream is set aside, the demonstration is one segment.
    constant_columns_ : dict of str to list of int
        Per stream, the constant columns left out of an otherwise informative stream.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 2.0, 400)
    >>> Y = np.column_stack([np.minimum(t, 1.0), np.maximum(t - 1.0, 0.0)])
    >>> seg = MultimodalSegmenter(window=16).fit(Demonstration.from_array(Y, t))
    >>> seg.result_.n_segments
    2
    >>> seg.get_params()["window"]
    16
    """

    def __init__(
        self, *, window="auto", min_size="auto", threshold=0.4, grace="auto", scale="relative",
        normalize="robust", stop_ratio=0.5, min_turn=45.0, stream_params=None, combine="evidence",
        stream_kinds=None, mode="deterministic", min_support=None, n_samples=20, min_hits=3, floor=0.05,
        random_state=None, phases=True,
    ):
        self.window = window
        self.min_size = min_size
        self.threshold = threshold
        self.grace = grace
        self.scale = scale
        self.normalize = normalize
        self.stop_ratio = stop_ratio
        self.min_turn = min_turn
        self.stream_params = stream_params
        self.combine = combine
        self.stream_kinds = stream_kinds
        self.mode = mode
        self.min_support = min_support
        self.n_samples = n_samples
        self.min_hits = min_hits
        self.floor = floor
        self.random_state = random_state
        self.phases = phases

    def _stream_settings(self, name: str, t: np.ndarray, auto_window: int) -> dict:
        raw = {k: getattr(self, k) for k in _STREAM_KEYS}
        overrides = (self.stream_params or {}).get(name, {})
        unknown = set(overrides) - set(_STREAM_KEYS)
        if unknown:
            raise ValueError(f"stream_params[{name!r}]: expected keys among {list(_STREAM_KEYS)}, "
                             f"got {sorted(unknown)}")
        raw.update(overrides)
        window = auto_window if raw["window"] == "auto" else to_samples(raw["window"], t, name="window")
        # evidence needs no second window between keypoints: two rests always have a movement between
        windows = 1 if self.combine == "evidence" else MIN_SIZE_WINDOWS
        min_size = windows * window if raw["min_size"] == "auto" else to_samples(
            raw["min_size"], t, name="min_size")
        grace = window if raw["grace"] == "auto" else (
            to_samples(raw["grace"], t, name="grace", allow_zero=True))
        threshold = check_fraction(raw["threshold"], name="threshold")
        if threshold == 0:
            raise ValueError("threshold: expected a number in (0, 1], got 0")
        stop_ratio = None if raw["stop_ratio"] is None else check_fraction(raw["stop_ratio"],
                                                                          name="stop_ratio")
        min_turn = None if raw["min_turn"] is None else check_fraction(raw["min_turn"], name="min_turn",
                                                                      low=0.0, high=180.0)
        return {"window": window, "min_size": min_size, "threshold": threshold, "grace": grace,
                "scale": raw["scale"], "normalize": raw["normalize"], "stop_ratio": stop_ratio,
                "min_turn": min_turn}

    @numerical_errors("MultimodalSegmenter.fit")
    def fit(self, demo: Demonstration, streams=None) -> MultimodalSegmenter:
        """Segment ``demo`` using ``streams`` (default: all of its streams).

        Parameters
        ----------
        demo : Demonstration
        streams : str or list of str, optional
            Names of the streams to segment on; default all of ``demo``'s.

        Returns
        -------
        self
            With :attr:`result_` set.
        """
        if not isinstance(demo, Demonstration):
            raise ValueError(f"demo: expected a skillbank.Demonstration, got {type(demo).__name__}")
        names = demo.stream_names if streams is None else (
            [streams] if isinstance(streams, str) else list(streams))
        if not names:
            raise ValueError("streams: expected at least one stream name, got none")
        missing = [s for s in names if s not in demo]
        if missing:
            raise ValueError(f"streams: expected names among {demo.stream_names}, got unknown {missing}")
        if self.stream_params is not None and not isinstance(self.stream_params, Mapping):
            raise ValueError(f"stream_params: expected a mapping, got {type(self.stream_params).__name__}")
        if self.mode not in ("deterministic", "sampling"):
            raise ValueError(f"mode: expected 'deterministic' or 'sampling', got {self.mode!r}")
        floor = check_fraction(self.floor, name="floor")
        if floor == 0:
            raise ValueError("floor: expected a number in (0, 1], got 0")
        if self.combine not in COMBINES:
            raise ValueError(f"combine: expected one of {list(COMBINES)}, got {self.combine!r}")
        if self.stream_kinds is not None and not isinstance(self.stream_kinds, Mapping):
            raise ValueError(f"stream_kinds: expected a mapping, got {type(self.stream_kinds).__name__}")
        if not isinstance(self.phases, bool | np.bool_):
            raise ValueError(f"phases: expected True or False, got {self.phases!r}")
        evidence = self.combine == "evidence"
        # the paper's product rule treats every stream as motion, as the paper does
        kinds = {name: stream_kind(name, self.stream_kinds) if evidence else "motion" for name in names}
        t, n = demo.t, demo.n_steps
        per_stream, speeds, set_aside, constant = {}, {}, {}, {}
        # each stream's constant columns and speed, computed once for the window and the cuts
        still_of, speed_of = {}, {}
        auto_window = _auto_window(demo, names, self.stream_kinds, still_of, speed_of)
        for name in names:
            p = self._stream_settings(name, t, auto_window)
            needed = max(MIN_SAMPLES, MIN_SEGMENTS * p["min_size"])
            if n < needed:
                raise ValueError(
                    f"demo: expected at least {_size_text(needed)} samples to segment stream "
                    f"{name!r} with min_size={_size_text(p['min_size'])}, got {n}; give a smaller min_size "
                    f"(or window)")
            _check_sizes(p, n)
            Y = demo[name]
            # a constant column has no boundary to show, and every measure below divides by its
            # spread: it is left out before any of them, and a stream of only such columns set aside
            still = still_of[name]
            if still.all():
                set_aside[name] = why_constant(Y)
                per_stream[name] = _nothing(name, p, n, kinds[name], 0.0 if evidence else floor)
                continue
            if still.any():
                constant[name] = np.flatnonzero(still).tolist()
                Y = Y[:, ~still]
            # the jerk norm serves the profile and the refinement, the speed
            # the relative scale, the time stamps' round-off and the gate: each is computed once
            speed = speed_of[name] if name in speed_of else speed_norm(t, Y)
            absj, j, prof, step = _stream_jerk(t, Y, speed, window=p["window"], scale=p["scale"],
                                               normalize=p["normalize"], grace=p["grace"])
            sigma = SIGMA_PER_WINDOW * p["window"]
            if kinds[name] == "motion":
                cps, strength = np.array([], dtype=int), np.array([], dtype=float)
                # with evidence and min_turn=None the gate's events are not used: they are not made
                if not evidence or p["min_turn"] is not None:
                    cps, strength = detect_changepoints(prof, threshold=p["threshold"],
                                                        min_size=p["min_size"], grace=p["grace"],
                                                        window=p["window"])
                    # the profile places an event to a sample or two; the raw jerk's centre pins it
                    cps = refine_to_jerk_centre(
                        cps, absj, half_width=max(MIN_REFINE_HALF_WIDTH, p["window"] // REFINE_DIVISOR))
                    if p["stop_ratio"] is not None:
                        cps, strength = _gate_changepoints(
                            cps, strength, Y, speed, window=p["window"], min_size=p["min_size"],
                            grace=p["grace"], stop_ratio=p["stop_ratio"],
                            min_turn=NO_TURN if p["min_turn"] is None else p["min_turn"])
                confidence = np.ones(cps.size)
                if evidence:
                    v = rest_speed(t, Y, speed, max_sigma=p["window"] / 4)
                    speeds[name] = v
                    if p["min_turn"] is not None and cps.size:
                        # the gate also keeps events where the speed merely dips below half its
                        # peak; as evidence those are rests (judged by the rest finder) or nothing:
                        # only events where the direction turns, within a window, are turns
                        cps = cps[turning(Y, cps, window=p["window"], min_turn=p["min_turn"])]
                    cps, confidence = motion_evidence(v, cps, window=p["window"], Y=Y,
                                                      min_size=p["min_size"]) if moves(t, Y, v) \
                        else (np.array([], dtype=int), np.array([], dtype=float))
                    strength = confidence
            elif kinds[name] == "contact":
                cps, confidence = contact_events(Y, window=p["window"])
                strength = confidence
            else:
                cps, confidence = discrete_events(Y)
                strength = confidence
            if evidence:
                # events too weak to matter are not reported (a held arm's sensor noise makes many)
                strong = confidence >= MIN_CONFIDENCE
                cps, strength, confidence = cps[strong], strength[strong], confidence[strong]
            curve = evidence_curve(cps, confidence, n, sigma) if evidence else \
                changepoint_probability(cps, n, sigma=sigma, floor=floor)
            per_stream[name] = StreamSegmentation(name, p, j, prof, cps, strength, curve, jerk_step=step,
                                                  kind=kinds[name], floor=0.0 if evidence else floor)
        active = {k: v for k, v in per_stream.items() if k not in set_aside}
        if active:
            prob, support, keypoints = self._keypoints(active, kinds, floor, n)
        else:
            # nothing moves, touches or switches: the demonstration is one segment
            prob, support, keypoints = np.zeros(n), np.zeros(n), np.array([], dtype=int)
        if evidence and speeds:
            keypoints = merge_motionless(keypoints, prob, demo, speeds)
        self.phases_ = demonstration_phases(demo, stream_kinds=self.stream_kinds) if self.phases else []
        if self.phases_:
            # the phases are the skills' units; the motion's pauses inside one are a person's halting
            keypoints = phase_bounds(self.phases_, n, min(p.params["min_size"] for p in per_stream.values()))
        self.set_aside_ = set_aside
        self.constant_columns_ = constant
        self.result_ = SegmentationResult(demo, per_stream, prob, support, keypoints, self.mode,
                                          {k: v.params for k, v in per_stream.items()}, self.combine,
                                          set_aside=dict(set_aside), constant_columns=dict(constant),
                                          phases=list(self.phases_))
        return self

    def _keypoints(self, streams: dict, kinds: dict, floor: float, n: int):
        """``(probability, support, keypoints)`` from the informative ``streams``' curves."""
        evidence = self.combine == "evidence"
        min_size = min(s.params["min_size"] for s in streams.values())
        window = min(s.params["window"] for s in streams.values())
        if evidence:
            prob, _ = combine_evidence({k: v.probability for k, v in streams.items()}, kinds)
            support = prob
        else:
            prob, support = combine_probabilities({k: v.probability for k, v in streams.items()},
                                                  floor=floor)
        if self.mode == "deterministic":
            if evidence:
                keypoints = keypoints_deterministic(prob, min_support=KEYPOINT_PROBABILITY, min_size=min_size)
            else:
                need = max(1.0, DEFAULT_SUPPORT_FRACTION * len(streams)) if self.min_support is None else \
                    check_positive(self.min_support, name="min_support")
                keypoints = keypoints_deterministic(support, min_support=need - SUPPORT_SLACK,
                                                    min_size=min_size)
        else:
            n_samples = check_positive(self.n_samples, name="n_samples", integer=True)
            if n_samples > MAX_DRAWS:
                raise ValueError(f"n_samples: expected at most {MAX_DRAWS} draws per round, got {n_samples}")
            min_hits = check_positive(self.min_hits, name="min_hits", integer=True)
            rng = np.random.default_rng(_check_random_state(self.random_state))
            draw = prob
            if evidence:
                # the evidence is a per-sample probability, not a distribution: normalise it to draw
                draw = prob / prob.sum() if prob.sum() > 0 else np.full(n, 1.0 / n)
            keypoints = keypoints_sampling(draw, n_samples=n_samples, min_hits=min_hits, window=window,
                                           min_size=min_size, rng=rng)
        return prob, support, keypoints


def _size_text(value: int) -> str:
    """A number of samples for a message: exact when short, in powers of ten when long."""
    return str(value) if value < 10**12 else f"{float(value):.3g}"


def _auto_window(demo: Demonstration, names, stream_kinds, still_of: dict, speed_of: dict) -> int:
    """``window="auto"``: 4 % of the demonstration, but never longer than its motion's time scale.

    The time scale is the speed's correlation time
    (:func:`~skillbank.segmentation.motion_time_scale`). In a demonstration of a
    handful of movements 4 % of it is the shorter (about a fifth of a movement,
    where the speed decorrelates over a third or more of one), so such
    demonstrations are cut as they always were; in a long recording the motion
    bounds the window, so the cost per sample and the cuts per minute stop
    growing with the recording's length. ``still_of`` receives every stream's
    constant columns and ``speed_of`` the speeds it measured, for the cuts.
    """
    n = demo.n_steps
    fraction = AUTO_WINDOW_FRACTION * n
    informative = {}
    for name in names:
        Y = demo[name]
        still = still_of[name] = constant_columns(Y)
        if not still.all():
            informative[name] = Y[:, ~still] if still.any() else Y
    motion = [name for name in informative if stream_kind(name, stream_kinds) == "motion"]
    # the motion streams carry the movements' time scale; a recording without one (a force
    # sensor alone) takes it from what it has
    chosen = motion or list(informative)
    window = fraction
    if chosen and fraction > MIN_AUTO_WINDOW:
        for k in chosen:
            speed_of[k] = speed_norm(demo.t, informative[k])
        window = min(fraction, motion_time_scale([speed_of[k] for k in chosen]))
    return max(MIN_AUTO_WINDOW, int(round(window)))


def _check_sizes(params: dict, n: int) -> None:
    """A window leaves room for a cut (two windows), and a grace period is within the demonstration."""
    window, grace = params["window"], params["grace"]
    if window > n // MIN_SEGMENTS:
        raise ValueError(f"window: expected at most {n // MIN_SEGMENTS} samples (half the demonstration's "
                         f"{n}), got {_size_text(window)}; give a smaller window")
    if grace > n:
        raise ValueError(f"grace: expected at most the demonstration's {n} samples, got {_size_text(grace)}")


def _check_random_state(value):
    """``random_state``: None, an integer >= 0 or a numpy Generator (numpy's own message names neither)."""
    if value is None or isinstance(value, np.random.Generator):
        return value
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ValueError(f"random_state: expected None, an integer >= 0 or a numpy Generator, got {value!r}")
    return int(value)


def _nothing(name: str, params: dict, n: int, kind: str, floor: float) -> StreamSegmentation:
    """The segmentation of a stream set aside as constant: no jerk, no events, only the floor."""
    zeros = np.zeros(n)
    return StreamSegmentation(name, params, zeros, zeros.copy(), np.array([], dtype=int), np.array([]),
                              np.full(n, floor), kind=kind, floor=floor)


def segment(demo: Demonstration, streams=None, **params) -> SegmentationResult:
    """Segment a demonstration; keyword arguments are :class:`MultimodalSegmenter`'s.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 1.0, 300)
    >>> segment(Demonstration.from_array(np.zeros((300, 3)), t)).n_segments
    1
    """
    return MultimodalSegmenter(**params).fit(demo, streams).result_
