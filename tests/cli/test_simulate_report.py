"""``sim run``'s report says why a button's peak force can be ten times what presses it (issue 44).

A 71.7 N peak on a button that needs 7 N read as a wrong number; past the
spring's 1.5 x the press force at full travel, the tool is pushing the button
against its end stop, and the line says so. The report is read from
``_report`` on a built result (no physics).
"""

from __future__ import annotations

from types import SimpleNamespace

from skillbank.cli._simulate import _report
from skillbank.simulation import PRESS_FORCE


def test_a_peak_past_the_end_stop_says_why(capsys):
    result = SimpleNamespace(
        duration=11.0, robot="ur5e", real_time_factor=3.0, ok=True, joint_max=0.01, tool_max=0.002,
        contacts=[], objects={}, facts={}, notes=[],
        buttons={"b1": {"pressed": True, "t": 3.902, "peak_force": 7.86},
                 "b2": {"pressed": True, "t": 11.012, "peak_force": 71.7}})
    _report(SimpleNamespace(trajectory="plan.csv"), result, [])
    lines = capsys.readouterr().out.splitlines()
    assert "  button b1: pressed (at 3.902 s), peak force 7.86 N" in lines  # under 1.5 x 7 N: nothing more
    assert PRESS_FORCE == 7.0
    assert ("  button b2: pressed (at 11.012 s), peak force 71.7 N (needs 7 N; past 10.5 N the tool pushes "
            "it against its end stop)") in lines
