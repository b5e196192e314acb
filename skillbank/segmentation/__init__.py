"""Probabilistic multimodal segmentation of demonstrations into motion primitives."""

from ._changepoints import detect_changepoints, refine_to_jerk_centre
from ._gate import gate_changepoints, smoothed_speed
from ._keypoints import (
    changepoint_probability,
    combine_probabilities,
    keypoints_deterministic,
    keypoints_sampling,
)
from ._profile import jerk, jerk_profile, normalize_profile, speed_norm, windowed_mean
from ._result import SegmentationResult, StreamSegmentation
from ._segmenter import MultimodalSegmenter, segment, to_samples

__all__ = [
    "MultimodalSegmenter", "SegmentationResult", "StreamSegmentation", "segment", "jerk", "jerk_profile",
    "windowed_mean", "normalize_profile", "detect_changepoints", "changepoint_probability",
    "combine_probabilities", "keypoints_deterministic", "keypoints_sampling", "to_samples",
    "refine_to_jerk_centre", "gate_changepoints", "smoothed_speed", "speed_norm",
]
