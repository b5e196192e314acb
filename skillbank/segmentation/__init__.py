"""Probabilistic multimodal segmentation of demonstrations into motion primitives.

:class:`MultimodalSegmenter` (or :func:`segment`) cuts a demonstration; it
returns a :class:`SegmentationResult` with a :class:`StreamSegmentation` per
stream. :func:`jerk`, :func:`jerk_profile`, :func:`detect_changepoints` and
:func:`gate_changepoints` are the per-stream steps, for studying one stream;
:func:`motion_time_scale` is the motion's own time scale, which bounds the
default window. :func:`demonstration_phases` is **the** home of a manipulation
demonstration's phases (reach, carry, retreat, per object), where the segmenter
cuts it and which relations, evaluation and composition read; :func:`part_joints`,
the joints a carried part of an articulated object moved about (a handle's
latch, then its door's hinge), found from the recorded poses; :func:`arm_constraints`, when
one arm's segment of a two-arm recording waited for the other arm's.
The other helpers live in the private modules and may change without notice.
"""

from ._arms import ArmSpan, arm_constraints
from ._changepoints import detect_changepoints
from ._gate import gate_changepoints
from ._joints import PartJoints, part_joints
from ._phases import PHASE_KINDS, Phase, carried, demonstration_phases, object_streams
from ._profile import jerk, jerk_profile
from ._result import SegmentationResult, StreamSegmentation
from ._segmenter import MultimodalSegmenter, segment
from ._timescale import motion_time_scale, speed_correlation_time

__all__ = [
    "MultimodalSegmenter", "segment", "SegmentationResult", "StreamSegmentation",
    "jerk", "jerk_profile", "detect_changepoints", "gate_changepoints",
    "motion_time_scale", "speed_correlation_time",
    "Phase", "PHASE_KINDS", "demonstration_phases", "carried", "object_streams",
    "PartJoints", "part_joints", "ArmSpan", "arm_constraints",
]
