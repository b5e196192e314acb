import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from skillbank.core._validation import (
    MAX_MAGNITUDE,
    check_array,
    check_finite_result,
    check_fraction,
    check_positive,
    check_time,
    numerical_errors,
    summarise,
)


def test_check_array_converts_and_keeps_values():
    out = check_array([[1, 2], [3, 4]], name="Y")
    assert out.dtype == np.float64
    np.testing.assert_array_equal(out, [[1, 2], [3, 4]])


@pytest.mark.parametrize(
    ("value", "kwargs", "match"),
    [
        ([[1.0, np.nan]], {}, r"Y: expected finite values, got 1 non-finite value\(s\) \(NaN"),
        ([[1.0, np.inf]], {}, r"Y: expected finite values.*inf first at index \(0, 1\)"),
        ([1.0, 2.0], {}, r"Y: expected a 2-D array, got 1-D"),
        (np.zeros((2, 2, 2)), {"ndim": (1, 2)}, r"Y: expected a 1-D or 2-D array, got 3-D"),
        ([["a", "b"]], {}, r"Y: expected an array of real numbers.*cannot be converted"),
        (np.zeros((3, 2)), {"min_samples": 4}, r"Y: expected at least 4 samples, got 3"),
        (np.zeros((3, 2)), {"n_dims": 3}, r"Y: expected 3 columns, got 2"),
        (np.zeros((3, 0)), {}, r"Y: expected at least one column"),
    ],
)
def test_check_array_errors(value, kwargs, match):
    with pytest.raises(ValueError, match=match):
        check_array(value, name="Y", **kwargs)


def test_check_array_as_2d():
    assert check_array([1.0, 2.0], name="g", ndim=(1, 2), as_2d=True).shape == (2, 1)


@pytest.mark.parametrize(
    ("value", "match"),
    [
        ([0.0, 1.0, 1.0], r"t: expected strictly increasing time, got t\[2\]=1.0 after t\[1\]=1.0"),
        ([0.0, 2.0, 1.0], r"t: expected strictly increasing time"),
        ([[0.0, 1.0]], r"t: expected a 1-D array, got 2-D"),
        ([0.0, np.nan], r"t: expected finite values"),
    ],
)
def test_check_time_errors(value, match):
    with pytest.raises(ValueError, match=match):
        check_time(value)


def test_check_time_length():
    with pytest.raises(ValueError, match=r"t: expected 3 samples to match the data, got 2"):
        check_time([0.0, 1.0], n_steps=3)


@pytest.mark.parametrize(
    ("value", "kwargs", "match"),
    [
        (0, {}, r"w: expected a number > 0, got 0"),
        (-1.0, {}, r"w: expected a number > 0, got -1.0"),
        (2.5, {"integer": True}, r"w: expected an integer > 0, got 2.5"),
        ("3", {}, r"w: expected a number > 0, got str"),
        (True, {}, r"w: expected a number > 0, got bool"),
        (float("nan"), {}, r"w: expected a number > 0, got nan"),
    ],
)
def test_check_positive_errors(value, kwargs, match):
    with pytest.raises(ValueError, match=match):
        check_positive(value, name="w", **kwargs)


def test_check_fraction():
    assert check_fraction(0.5, name="x") == 0.5
    with pytest.raises(ValueError, match=r"x: expected a number in \[0.0, 1.0\], got 1.5"):
        check_fraction(1.5, name="x")


finite_2d = hnp.arrays(
    np.float64,
    hnp.array_shapes(min_dims=2, max_dims=2, min_side=1, max_side=20),
    elements=st.floats(-1e6, 1e6),
)


@given(finite_2d)
def test_property_finite_arrays_pass_unchanged(arr):
    np.testing.assert_array_equal(check_array(arr, name="Y"), arr)


@given(finite_2d, st.data())
def test_property_any_nonfinite_value_is_rejected(arr, data):
    i = data.draw(st.integers(0, arr.shape[0] - 1))
    j = data.draw(st.integers(0, arr.shape[1] - 1))
    arr = arr.copy()
    arr[i, j] = data.draw(st.sampled_from([np.nan, np.inf, -np.inf]))
    with pytest.raises(ValueError, match=r"Y: expected finite values"):
        check_array(arr, name="Y")


@given(hnp.arrays(np.float64, st.integers(2, 50), elements=st.floats(-1e6, 1e6)))
def test_property_time_is_accepted_iff_strictly_increasing(t):
    if np.all(np.diff(t) > 0):
        np.testing.assert_array_equal(check_time(t), t)
    else:
        with pytest.raises(ValueError, match=r"t: expected strictly increasing time"):
            check_time(t)


def test_params_protocol_matches_scikit_learn():
    """core._params.Params gives what sklearn.base.BaseEstimator gives, so sklearn's tools work."""
    from sklearn.base import BaseEstimator, clone

    from skillbank.core._params import Params
    from skillbank.representations import ProMP

    class Inner(Params):
        def __init__(self, *, gamma=1.0):
            self.gamma = gamma

    class Mine(Params):
        def __init__(self, *, alpha=1.0, inner=None, label="x"):
            self.alpha, self.inner, self.label = alpha, inner, label

    class Theirs(BaseEstimator):
        def __init__(self, *, alpha=1.0, inner=None, label="x"):
            self.alpha, self.inner, self.label = alpha, inner, label

    for kwargs in ({}, {"alpha": 2.0}, {"inner": Inner(gamma=3.0), "label": "y"}):
        mine, theirs = Mine(**kwargs), Theirs(**kwargs)
        assert mine.get_params(deep=True).keys() == theirs.get_params(deep=True).keys()
        assert mine.get_params(deep=False) == theirs.get_params(deep=False)
        assert repr(mine).replace("Mine", "Theirs") == repr(theirs)
        copy = clone(mine)
        assert type(copy) is Mine and copy is not mine
        assert repr(copy) == repr(mine)
    nested = Mine(inner=Inner()).set_params(inner__gamma=5.0, alpha=0.5)
    assert nested.inner.gamma == 5.0 and nested.alpha == 0.5
    with pytest.raises(ValueError, match=r"set_params: Mine has no parameter 'beta'"):
        Mine().set_params(beta=1)
    model = clone(ProMP(n_basis=7, random_state=3))
    assert model.get_params() == ProMP(n_basis=7, random_state=3).get_params()


# ---------------------------------------------------------------- numbers at the edges (issue 12)


@pytest.mark.parametrize(
    ("value", "match"),
    [
        ([[0.0, 1e101]], r"^Y: expected values of magnitude at most 1e\+100 .*got 1e\+101 at index \(0, 1\) "
                         r"\(1 such value\(s\)\)$"),
        ([[-1e300], [-1e300]], r"got -1e\+300 at index \(0, 0\) \(2 such value\(s\)\)"),
        ([[1.0 + 2.0j]], r"^Y: expected real numbers, got complex values \(an array of shape \(1, 1\) and "
                         r"dtype complex128\)$"),
        (np.array([[1.0, 2j]], dtype=object), r"^Y: expected real numbers, got complex values"),
    ],
)
def test_check_array_bounds_magnitudes_and_rejects_complex(value, match):
    with pytest.raises(ValueError, match=match):
        check_array(value, name="Y")


def test_check_array_accepts_the_bound_itself():
    edge = [[MAX_MAGNITUDE, -MAX_MAGNITUDE, 1e-300, 0.0]]
    np.testing.assert_array_equal(check_array(edge, name="Y"), edge)


def test_check_time_bounds_and_collapsed_stamps():
    with pytest.raises(ValueError, match=r"^t: expected values of magnitude at most 1e\+100"):
        check_time([0.0, 1e302])
    # Distinct as written, equal in float64 at this magnitude: a repeated stamp after all.
    with pytest.raises(ValueError, match=r"^t: expected strictly increasing time, got t\[1\]=1e\+20"):
        check_time([1e20, 1e20 + 1.0])


@pytest.mark.parametrize(
    ("value", "kwargs", "match"),
    [
        (1e101, {}, r"^w: expected a number > 0 and at most 1e\+100 \(larger ones overflow the solvers\), "
                    r"got 1e\+101$"),
        (10**400, {"integer": True}, r"^w: expected an integer > 0 of magnitude at most 1e\+100, got an "
                                     r"integer of 401 digits$"),
        (1 + 2j, {}, r"^w: expected a real number, got complex \(1\+2j\)$"),
        (np.complex128(1.0), {}, r"^w: expected a real number, got complex"),
    ],
)
def test_check_positive_bounds_and_complex(value, kwargs, match):
    with pytest.raises(ValueError, match=match):
        check_positive(value, name="w", **kwargs)


def test_check_fraction_rejects_complex():
    with pytest.raises(ValueError, match=r"^x: expected a real number, got complex"):
        check_fraction(0.5j, name="x")


def test_check_finite_result():
    assert check_finite_result(2.0, name="step") == 2.0
    with pytest.raises(ValueError, match=r"^step: produced 1 non-finite value\(s\) \(NaN\): the input's"):
        check_finite_result(float("nan"), name="step")
    with pytest.raises(ValueError, match=r"^step: produced 2 non-finite value\(s\) \(inf first at index "
                                         r"\(1, 0\)\)"):
        check_finite_result(np.array([[0.0], [np.inf], [-np.inf]]), name="step")


def _warn(category):
    import warnings

    warnings.warn("the solver is unhappy", category, stacklevel=2)


@pytest.mark.parametrize(
    ("body", "detail"),
    [
        (lambda: np.float64(1e300) * 1e300, r"overflow encountered in scalar multiply"),
        (lambda: np.array([1.0]) / 0.0, r"divide by zero encountered in divide"),
        (lambda: np.sqrt(np.array([-1.0])), r"invalid value encountered in sqrt"),
        (lambda: 1e200**2, r"\(34, 'Numerical result out of range'\)"),
        (lambda: np.linalg.cholesky(-np.eye(2)), r"Matrix is not positive definite"),
        (lambda: _warn(RuntimeWarning), r"the solver is unhappy"),
        (lambda: _warn(np.exceptions.ComplexWarning), r"the solver is unhappy"),
        (lambda: _warn(__import__("scipy.linalg").linalg.LinAlgWarning), r"the solver is unhappy"),
    ],
    ids=["overflow", "divide", "invalid", "python-overflow", "linalg-error", "runtime-warning",
         "complex-warning", "linalg-warning"],
)
def test_numerical_errors_become_one_value_error_naming_the_step(body, detail):
    match = (rf"^solve: the computation overflowed or became undefined \({detail}\); the input's "
             r"magnitudes or time steps are beyond what it handles$")
    with pytest.raises(ValueError, match=match):
        with numerical_errors("solve"):
            body()


def test_numerical_errors_leave_other_errors_and_local_errstate_alone():
    with pytest.raises(ValueError, match=r"^Y: expected finite values"):
        with numerical_errors("solve"):
            check_array([np.nan], name="Y", ndim=1)
    with numerical_errors("solve"), np.errstate(divide="ignore"):  # code that expects infinities
        assert np.isinf(np.array([1.0]) / 0.0).all()

    @numerical_errors("decorated")
    def f(x):
        return np.exp(x)

    assert f(1.0) == np.exp(1.0)
    with pytest.raises(ValueError, match=r"^decorated: the computation overflowed"):
        f(1e4)


def test_summarise():
    assert summarise([]) == ""
    assert summarise(["a", "b", "c"]) == "a, b, c"
    assert summarise(range(1000), sep="; ") == "0; 1; 2 and 997 more"
    assert summarise(range(12), limit=10).endswith("9 and 2 more")


@given(hnp.arrays(np.float64, st.integers(1, 30), elements=st.floats(allow_nan=False, allow_infinity=False)))
def test_property_values_are_accepted_iff_within_the_bound(arr):
    if np.all(np.abs(arr) <= MAX_MAGNITUDE):
        np.testing.assert_array_equal(check_array(arr, name="Y", ndim=1), arr)
    else:
        with pytest.raises(ValueError, match=r"^Y: expected values of magnitude at most 1e\+100"):
            check_array(arr, name="Y", ndim=1)
