"""The suite gives the same answer on every run: Hypothesis is derandomised in CI (issue 23, item 1)."""

import os

from hypothesis import settings


def test_ci_runs_the_same_examples_and_a_developer_new_ones():
    current = settings()
    if os.environ.get("CI") or os.environ.get("SKILLBANK_HYPOTHESIS") == "ci":
        # the same examples every run, and no example database carried from one run to the next
        assert current.derandomize is True and current.database is None
    else:
        # new examples each run, so a property that can fail is found by a developer, not by CI
        assert current.derandomize is False
