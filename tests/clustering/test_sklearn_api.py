"""scikit-learn's own estimator checks on ElasticClustering."""

from __future__ import annotations

from sklearn.utils.estimator_checks import parametrize_with_checks

from skillbank.clustering import ElasticClustering

# Checks that do not apply, each with the reason.
_EXPECTED_FAILED = {
    "check_dtype_object": (
        "skillbank's validator reports non-numeric input as ValueError (the project's convention for "
        "bad user input), where scikit-learn expects TypeError"
    ),
}


@parametrize_with_checks(
    [ElasticClustering(random_state=0), ElasticClustering(criterion="paper", random_state=0)],
    expected_failed_checks=lambda est: _EXPECTED_FAILED,
)
def test_sklearn_compatible(estimator, check):
    check(estimator)
