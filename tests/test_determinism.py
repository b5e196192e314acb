"""The suite gives the same answer on every run: Hypothesis is derandomised in CI (issue 23, item 1)."""

import os

import pytest
from hypothesis import settings


@pytest.mark.skipif(not os.environ.get("CI") and os.environ.get("SKILLBANK_HYPOTHESIS") != "ci",
                    reason="the ci profile is selected when CI is set (or SKILLBANK_HYPOTHESIS=ci)")
def test_properties_are_derandomised_without_an_example_database_in_ci():
    current = settings()
    assert current.derandomize is True
    assert current.database is None


def test_a_developer_run_draws_new_examples():
    # outside CI the examples are random, so a property that can fail is found by a developer
    if os.environ.get("CI") or os.environ.get("SKILLBANK_HYPOTHESIS") == "ci":
        pytest.skip("CI runs the derandomised profile")
    assert settings().derandomize is False
