"""When one arm's segment waits for another arm: the moments two arms depend on each other.

A two-arm demonstration is cut per arm (each arm's tool, gripper and objects), so each arm's segments
say nothing of the other's. What ties them is the demonstration's one clock: a segment of one arm began
after a segment of the other had ended (the receiving hand closed on the hammer before the giving hand
opened), and two segments in which both hands held on began together (a pot rises only once both hands
hold its handles). :func:`arm_constraints` reads both from the segments' sample ranges in the recording
and the gripper commanded at their start; a reproduction lets a segment begin only once they hold.
"""

from __future__ import annotations

from typing import NamedTuple

__all__ = ["ArmSpan", "arm_constraints"]


class ArmSpan(NamedTuple):
    """One segment of one arm in the recording: samples ``start:stop`` of the one clock both arms share,
    and whether its gripper was commanded shut as it began (``holding``)."""

    start: int
    stop: int
    holding: bool


def arm_constraints(spans) -> list:
    """For each arm's each segment, how many segments of each other arm must have begun or ended first.

    Parameters
    ----------
    spans : list of list of ArmSpan
        Per arm, its segments in order, on the recording's one clock.

    Returns
    -------
    list of list of dict
        ``need[b][j] = {a: m}``: arm ``b``'s segment ``j`` begins once arm ``a`` has begun its segment
        ``m`` (so its first ``m`` segments have ended). ``m`` counts arm ``a``'s segments that ended by
        the time ``j`` began (the recording's order of events), and is at least the index of a
        segment of ``a`` that overlaps ``j`` while both arms hold on at their start (the two begin
        together: neither hand lifts what the other has not yet got). Arms with nothing to wait for are
        left out.

    Examples
    --------
    Arm 1 reaches longer than arm 0; both then lift together:

    >>> spans = [[ArmSpan(0, 50, False), ArmSpan(50, 90, True)],
    ...          [ArmSpan(0, 60, False), ArmSpan(60, 90, True)]]
    >>> arm_constraints(spans)
    [[{}, {1: 1}], [{}, {0: 1}]]
    """
    need = []
    for b, own in enumerate(spans):
        rows = []
        for seg in own:
            row = {}
            for a, other in enumerate(spans):
                if a == b:
                    continue
                m = sum(1 for s in other if s.stop <= seg.start)
                if seg.holding:
                    together = [i for i, s in enumerate(other)
                                if s.holding and s.start < seg.stop and seg.start < s.stop]
                    if together:
                        m = max(m, together[0])
                if m:
                    row[a] = m
            rows.append(row)
        need.append(rows)
    return need
