"""When one arm's segment waits for the other's: read from the recording's one clock."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from skillbank.segmentation import ArmSpan, arm_constraints


def test_a_handover_waits_for_the_receiving_hand():
    # arm 0 carries the hammer over and opens once arm 1 has closed on it (arm 1's reach ends at 70)
    giver = [ArmSpan(0, 40, False), ArmSpan(40, 80, True), ArmSpan(80, 100, False)]
    taker = [ArmSpan(0, 70, False), ArmSpan(70, 100, True)]
    need = arm_constraints([giver, taker])
    assert need[0][2] == {1: 1}  # the giver lets go only after the taker's reach (and grasp) ended
    assert need[1][0] == {} and need[1][1] == {0: 1}  # the taker's carry follows the giver's pick
    assert need[0][0] == {}


def test_two_hands_on_a_pot_lift_together_however_their_reaches_were_cut():
    # arm 0's lift began at 50, before arm 1's reach ended (60): the recording's order alone would let
    # arm 0 lift with one hand; both held on over 60-90, so they begin together
    spans = [[ArmSpan(0, 50, False), ArmSpan(50, 90, True)], [ArmSpan(0, 60, False), ArmSpan(60, 90, True)]]
    assert arm_constraints(spans) == [[{}, {1: 1}], [{}, {0: 1}]]


def test_arms_that_never_met_wait_for_nothing():
    spans = [[ArmSpan(0, 30, False)], [ArmSpan(0, 30, False)]]
    assert arm_constraints(spans) == [[{}], [{}]]


@st.composite
def _arms(draw):
    arms = []
    for _ in range(draw(st.integers(2, 3))):
        cuts = sorted(draw(st.sets(st.integers(1, 199), min_size=0, max_size=5)))
        bounds = [0, *cuts, 200]
        arms.append([ArmSpan(a, b, draw(st.booleans())) for a, b in zip(bounds, bounds[1:], strict=False)])
    return arms


@settings(derandomize=True, max_examples=200, deadline=None)
@given(_arms())
def test_the_recording_itself_meets_every_constraint_and_no_wait_is_circular(arms):
    need = arm_constraints(arms)
    for b, own in enumerate(arms):
        for j, seg in enumerate(own):
            for a, m in need[b][j].items():
                assert a != b and 0 < m <= len(arms[a])
                # in the recording arm a's first m segments had ended when b began j, or a's segment m
                # began together with j (both holding on, overlapping)
                ended = arms[a][m - 1].stop <= seg.start
                together = m < len(arms[a]) and arms[a][m].holding and seg.holding and \
                    arms[a][m].start < seg.stop and seg.start < arms[a][m].stop
                assert ended or together
    # the executor's gates: an arm at gate j has "reached" j; it passes once every other arm named has
    # reached as far; every arm gets through all its segments (no two arms wait on each other forever)
    reached = [0] * len(arms)
    moved = True
    while moved:
        moved = False
        for b in range(len(arms)):
            j = reached[b]
            if j < len(arms[b]) and all(reached[a] >= m for a, m in need[b][j].items()):
                reached[b] += 1
                moved = True
    assert reached == [len(a) for a in arms]


def test_spans_are_not_checked_for_the_caller():
    with pytest.raises(TypeError):
        arm_constraints([[ArmSpan(0, 1)]])
