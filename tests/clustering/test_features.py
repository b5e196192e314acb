"""Featurisers: angular similarity, resampled shapes, DTW landmarks."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone

from skillbank import Demonstration
from skillbank.clustering import (
    AngularSimilarityFeatures,
    DTWFeatures,
    ElasticClustering,
    TrajectoryFeatures,
)
from skillbank.core import resample_many as resample_trajectories
from skillbank.metrics import angular_similarity, dtw_distance


def random_walks(n, n_steps, n_dims=3, seed=0):
    rng = np.random.default_rng(seed)
    return np.cumsum(rng.normal(size=(n, n_steps, n_dims)), axis=1)


def loop_angular(A, B):
    """The README's definition, one step at a time."""
    n = len(A)
    total = 0.0
    for t in range(n - 1):
        u, v = A[t + 1] - A[t], B[t + 1] - B[t]
        nu, nv = np.linalg.norm(u), np.linalg.norm(v)
        if nu == 0.0 or nv == 0.0:
            continue
        total += np.arccos(np.clip(np.dot(u, v) / (nu * nv), -1.0, 1.0)) / np.pi
    return total / n


# -- angular similarity ---------------------------------------------------------------------------

def test_angular_similarity_matches_the_loop_definition():
    walks = random_walks(6, 40)
    walks[0, 10:13] = walks[0, 10]  # zero-length steps count 0
    reps = walks[:2]
    features = AngularSimilarityFeatures(representatives=list(reps)).fit_transform(list(walks))
    expected = np.array([[loop_angular(w, r) for r in reps] for w in walks])
    np.testing.assert_allclose(features, expected, rtol=1e-10, atol=1e-7)
    assert angular_similarity(walks[2], walks[3]) == pytest.approx(loop_angular(walks[2], walks[3]), abs=1e-7)


def test_one_angular_similarity_for_metrics_and_clustering():
    from skillbank import metrics
    from skillbank.metrics._shape import angular_similarity_matrix

    assert angular_similarity is metrics.angular_similarity
    walks = random_walks(5, 25, n_dims=2, seed=4)
    demos = [Demonstration.from_array(w, dt=0.1) for w in walks]
    M = angular_similarity_matrix(walks[:3], walks[3:])
    expected = [[loop_angular(a, b) for b in walks[3:]] for a in walks[:3]]
    np.testing.assert_allclose(M, expected, rtol=1e-10, atol=1e-12)
    assert angular_similarity(demos[0], demos[4]) == pytest.approx(M[0, 1], abs=1e-15)
    with pytest.raises(ValueError, match=r"B: expected trajectories of shape \(25, 2\)"):
        angular_similarity_matrix(walks[:3], walks[3:, :20])


def test_angular_similarity_known_values():
    t = np.linspace(0.0, 1.0, 11)[:, None]
    assert angular_similarity(t, t) == pytest.approx(0.0, abs=1e-7)
    # Opposite directions: angle pi at each of the n - 1 steps, divided by n (not n - 1).
    assert angular_similarity(t, -t) == pytest.approx(10 / 11)
    square = np.column_stack([t.ravel(), np.zeros(11)])
    turned = np.column_stack([np.zeros(11), t.ravel()])
    assert angular_similarity(square, turned) == pytest.approx(0.5 * 10 / 11)
    still = np.zeros((11, 2))
    assert angular_similarity(square, still) == 0.0


def test_angular_features_accept_demonstrations_and_3d_arrays():
    walks = random_walks(4, 30)
    demos = [Demonstration.from_array(w, dt=0.01) for w in walks]
    a = AngularSimilarityFeatures(representatives=demos[:2]).fit_transform(demos)
    b = AngularSimilarityFeatures(representatives=walks[:2]).fit_transform(walks)
    np.testing.assert_allclose(a, b)
    assert clone(AngularSimilarityFeatures(representatives=demos[:1])).representatives is not None
    names = AngularSimilarityFeatures(representatives=demos[:2]).fit(demos).get_feature_names_out()
    assert names.tolist() == ["angular_similarity0", "angular_similarity1"]


def test_angular_similarity_errors():
    with pytest.raises(ValueError, match=r"Q: expected the same number of samples as P \(5\), got 6"):
        angular_similarity(np.zeros((5, 2)), np.zeros((6, 2)))
    model = AngularSimilarityFeatures(representatives=[np.zeros((5, 2))]).fit()
    with pytest.raises(ValueError, match=r"X: angular similarity needs trajectories of equal length"):
        model.transform([np.zeros((5, 2)), np.zeros((7, 2))])
    with pytest.raises(ValueError, match=r"X: expected trajectories with 2 dimensions"):
        model.transform([np.zeros((5, 3))])
    with pytest.raises(ValueError, match=r"Q: expected 2 columns to match P, got 3"):
        angular_similarity(np.zeros((5, 2)), np.zeros((5, 3)))
    with pytest.raises(ValueError, match=r"Q: expected a Demonstration with a 'position' stream"):
        angular_similarity(np.zeros((5, 2)), Demonstration(np.arange(5.0), {"force": np.zeros((5, 2))}))
    with pytest.raises(ValueError, match=r"X: expected a list of \(n_steps, n_dims\) trajectories or a 3-D "
                                         r"array, got a 2-D array"):
        model.transform(np.zeros((5, 2)))
    with pytest.raises(ValueError, match=r"X: expected at least one trajectory, got none"):
        model.transform([])
    with pytest.raises(ValueError, match=r"expected a Demonstration with a 'position' stream"):
        model.transform([Demonstration(np.arange(5.0), {"force": np.zeros((5, 2))})])
    with pytest.raises(ValueError, match=r"representatives\[0\]: expected finite values"):
        AngularSimilarityFeatures(representatives=[np.full((5, 2), np.nan)]).fit()


# -- resampling and TrajectoryFeatures ------------------------------------------------------------

def test_resampling_matches_per_trajectory_interpolation():
    rng = np.random.default_rng(1)
    trajs = [np.cumsum(rng.normal(size=(n, 2)), axis=0) for n in (2, 7, 50, 13)]
    trajs.append(np.zeros((1, 2)))  # a single sample
    trajs.append(np.repeat([[1.0, 2.0]], 5, axis=0))  # never moves: falls back to time
    times = [np.sort(rng.uniform(0, 10, len(a))) + np.arange(len(a)) for a in trajs]
    for by in ("arc_length", "time"):
        got = resample_trajectories(trajs, times, 9, by)
        for a, t, g in zip(trajs, times, got, strict=True):
            if by == "arc_length":
                s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(a, axis=0), axis=1))])
            else:
                s = t - t[0]
            if s[-1] == 0.0:
                s = (t - t[0]) if t[-1] > t[0] else np.zeros(len(a))
            if s[-1] == 0.0:
                np.testing.assert_allclose(g, np.repeat(a[:1], 9, axis=0))
                continue
            q = np.linspace(0.0, 1.0, 9) * s[-1]
            want = np.column_stack([np.interp(q, s, a[:, k]) for k in range(a.shape[1])])
            np.testing.assert_allclose(g, want, atol=1e-9)


def test_trajectory_features_are_invariant_to_the_start_and_sampling():
    t = np.linspace(0.0, 1.0, 200)
    shape = np.column_stack([t, np.sin(3 * t), t**2])
    dense = shape
    sparse = shape[::3]
    shifted = shape + [5.0, -2.0, 1.0]
    f = TrajectoryFeatures(n_points=24, n_components=None).fit([dense, sparse, shifted])
    F = f.transform([dense, sparse, shifted])
    np.testing.assert_allclose(F[0], F[2], atol=1e-12)
    np.testing.assert_allclose(F[0], F[1], atol=0.02)  # chords of the sparse samples
    assert F.shape == (3, 24 * 3)


def test_trajectory_features_scale_and_pca():
    t = np.linspace(0.0, 1.0, 60)
    small = np.column_stack([t, t**2])
    big = 10.0 * small
    raw = TrajectoryFeatures(n_points=10, n_components=None).fit_transform([small, big])
    per_length = TrajectoryFeatures(n_points=10, n_components=None, scale="path_length")
    scaled = per_length.fit_transform([small, big])
    assert not np.allclose(raw[0], raw[1])
    np.testing.assert_allclose(scaled[0], scaled[1], atol=1e-12)
    walks = random_walks(20, 50, 2)
    model = TrajectoryFeatures(n_points=16, n_components=3, random_state=0)
    F = model.fit_transform(list(walks))
    assert F.shape == (20, 3)
    np.testing.assert_allclose(model.transform(list(walks)), F, atol=1e-9)


def test_trajectory_features_errors():
    with pytest.raises(ValueError, match=r"n_points: expected an integer >= 2, got 1"):
        TrajectoryFeatures(n_points=1).fit([np.zeros((4, 2))] * 3)
    with pytest.raises(ValueError, match=r"by: expected 'arc_length' or 'time', got 'speed'"):
        TrajectoryFeatures(by="speed").fit([np.zeros((4, 2))] * 3)
    with pytest.raises(ValueError, match=r"scale: expected 'none' or 'path_length', got 'unit'"):
        TrajectoryFeatures(scale="unit").fit([np.zeros((4, 2))] * 3)
    with pytest.raises(ValueError, match=r"X: expected at least 2 trajectories to fit the PCA, got 1"):
        TrajectoryFeatures().fit([np.zeros((4, 2))])
    with pytest.raises(ValueError, match=r"X: every trajectory has the same shape .* pass n_components=None"):
        TrajectoryFeatures().fit([np.ones((10, 2)), np.zeros((3, 2))])
    model = TrajectoryFeatures(n_components=None).fit([np.zeros((4, 2))])
    with pytest.raises(ValueError, match=r"X: expected trajectories with 2 dimensions, got 3"):
        model.transform([np.zeros((4, 3))])


def test_trajectory_features_feed_elastic_clustering():
    # Two skills, started anywhere: lines and arcs, 10 noisy demos each, lengths 40..80.
    rng = np.random.default_rng(2)
    demos, truth = [], []
    for k in range(20):
        n = int(rng.integers(40, 80))
        s = np.linspace(0.0, 1.0, n)
        if k % 2 == 0:
            path = np.column_stack([s, 0.0 * s])
        else:
            path = np.column_stack([np.sin(s * 2), 1 - np.cos(s * 2)])
        demos.append(path + rng.normal(0, 0.01, size=path.shape) + rng.uniform(-5, 5, size=2))
        truth.append(k % 2)
    F = TrajectoryFeatures(n_points=16, n_components=2, random_state=0).fit_transform(demos)
    labels = ElasticClustering(random_state=0).fit_predict(F)
    assert len(np.unique(labels)) == 2
    assert np.array_equal(labels == labels[0], np.array(truth) == truth[0])


# -- DTW ------------------------------------------------------------------------------------------

def loop_dtw(a, b, radius=None):
    n, m = len(a), len(b)
    D = np.full((n + 1, m + 1), np.inf)
    D[0, 0] = 0.0
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            if radius is not None and abs((j - 1) - (i - 1) * (m - 1) / max(n - 1, 1)) > radius + 1e-9:
                continue
            cost = np.linalg.norm(a[i - 1] - b[j - 1])
            D[i, j] = cost + min(D[i - 1, j - 1], D[i - 1, j], D[i, j - 1])
    return D[n, m]


@pytest.mark.parametrize(("n", "m"), [(1, 1), (1, 5), (5, 1), (12, 12), (9, 17), (20, 6)])
def test_dtw_matches_the_textbook_recurrence(n, m):
    rng = np.random.default_rng(n * 100 + m)
    a, b = rng.normal(size=(n, 2)), rng.normal(size=(m, 2))
    assert dtw_distance(a, b) == pytest.approx(loop_dtw(a, b), rel=1e-12)


def test_dtw_band_matches_the_textbook_recurrence():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(30, 3)), rng.normal(size=(30, 3))
    radius = max(1.0, 0.1 * 30)
    assert dtw_distance(a, b, window=0.1) == pytest.approx(loop_dtw(a, b, radius=np.ceil(radius)), rel=1e-12)
    assert dtw_distance(a, b, window=0.1) >= dtw_distance(a, b)


def test_dtw_features_see_through_time_warping():
    t = np.linspace(0.0, 1.0, 120)
    shape = lambda u: np.column_stack([np.sin(2 * np.pi * u), np.cos(3 * np.pi * u)])  # noqa: E731
    slow_start = shape(t**1.6)
    other = np.column_stack([t, -t])
    model = DTWFeatures(n_landmarks=2, n_points=48).fit([shape(t), other])
    F = model.transform([shape(t), slow_start, other])
    assert np.linalg.norm(F[0] - F[1]) < 0.2 * np.linalg.norm(F[0] - F[2])
    pointwise = TrajectoryFeatures(n_points=48, n_components=None, by="time").fit_transform(
        [shape(t), slow_start, other])
    assert np.linalg.norm(pointwise[0] - pointwise[1]) > 0.2 * np.linalg.norm(pointwise[0] - pointwise[2])


def test_dtw_features_landmarks_and_errors():
    walks = list(random_walks(10, 30, 2))
    model = DTWFeatures(n_landmarks=4, n_points=16).fit(walks)
    assert model.landmarks_.shape == (4, 16, 2) and len(set(model.landmark_indices_)) == 4
    F = model.transform(walks)
    assert F.shape == (10, 4)
    np.testing.assert_allclose(F[model.landmark_indices_, np.arange(4)], 0.0, atol=1e-12)
    same = DTWFeatures(n_landmarks=5).fit([walks[0]] * 3)
    assert same.landmarks_.shape[0] == 1  # every trajectory coincides with the first landmark
    with pytest.raises(ValueError, match=r"window: expected a number in \[0.0, 1.0\], got 2.0"):
        DTWFeatures(window=2.0).fit(walks)
    with pytest.raises(ValueError, match=r"n_landmarks: expected an integer > 0, got 0"):
        DTWFeatures(n_landmarks=0).fit(walks)
    with pytest.raises(ValueError, match=r"X: expected trajectories with 2 dimensions, got 3"):
        model.transform([np.zeros((5, 3))])


def test_mismatch_messages_are_summarised():
    """Issue 12, item 6: one short line, however many trajectories disagree."""
    rng = np.random.default_rng(0)
    trajs = [rng.normal(size=(10 + k, 2)) for k in range(500)]
    with pytest.raises(ValueError, match=r"lengths 10, 11, 12 and 497 more; resample them first$"):
        AngularSimilarityFeatures(representatives=trajs).fit()
    mixed = [np.zeros((5, 2))] + [np.zeros((5, 3))] * 400
    match = (r"^X: expected every trajectory to have the same number of dimensions, got X\[0\] has 2, "
             r"X\[1\] has 3, X\[2\] has 3, X\[3\] has 3 and 397 more$")
    with pytest.raises(ValueError, match=match):
        TrajectoryFeatures().fit(mixed)
