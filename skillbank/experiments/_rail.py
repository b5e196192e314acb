"""The paper's clustering experiment on the RAIL dataset (Fig. 4), and an unsupervised default."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from sklearn.cluster import AgglomerativeClustering
from sklearn.metrics import adjusted_rand_score
from sklearn.preprocessing import minmax_scale

from ..clustering import AngularSimilarityFeatures, ElasticClustering, HeadingFeatures
from ..io import load_rail
from ..plotting import plot_cluster_comparison

__all__ = [
    "RailExperimentResult",
    "rail_experiment",
    "run_rail_experiment",
    "composition",
    "count_misclustered",
    "PAPER_REPRESENTATIVES",
]

#: The paper's representative demo of each class, indexed in the authors' file order.
PAPER_REPRESENTATIVES = {"reaching": 28, "pushing": 29, "writing": 0}
_MODES = ("default", "paper")
_KNOWN = ("reaching", "pushing", "pressing", "writing")


def composition(labels, classes, n_classes: int | None = None) -> np.ndarray:
    """Counts of each class in each cluster, shape ``(n_clusters, n_classes)``.

    Examples
    --------
    >>> composition([0, 0, 1], [1, 0, 0]).tolist()
    [[1, 1], [1, 0]]
    """
    labels, classes = np.asarray(labels, dtype=np.intp), np.asarray(classes, dtype=np.intp)
    if labels.shape != classes.shape:
        raise ValueError(f"labels: expected one label per demo ({classes.shape[0]}), got {labels.shape[0]}")
    k = int(labels.max()) + 1 if labels.size else 0
    c = int(classes.max()) + 1 if n_classes is None else int(n_classes)
    table = np.zeros((k, c), dtype=np.intp)
    np.add.at(table, (labels, classes), 1)
    return table


def count_misclustered(labels, classes) -> int:
    """Demos whose class is not the majority class of their cluster (the paper's measure).

    Examples
    --------
    >>> count_misclustered([0, 0, 0, 1], [0, 0, 1, 1])
    1
    """
    table = composition(labels, classes)
    return int(table.sum() - table.max(axis=1).sum())


@dataclass
class RailExperimentResult:
    """Everything one run of the RAIL experiment produced.

    ``summary()`` gives the JSON-ready dictionary returned by
    :func:`run_rail_experiment`; the arrays are kept for figures.
    """

    mode: str
    classes: list
    class_index: np.ndarray
    trajectories: list
    features: np.ndarray
    labels: dict
    n_clusters: dict
    feature_description: str
    method_description: dict
    timing: dict = field(default_factory=dict)

    @property
    def n_demos(self) -> int:
        return int(self.class_index.shape[0])

    def summary(self) -> dict:
        """Per method: compositions, n_clusters, misclustered, ari; n_demos; timing."""
        out = {
            "mode": self.mode,
            "classes": list(self.classes),
            "n_demos": self.n_demos,
            "class_counts": np.bincount(self.class_index, minlength=len(self.classes)).tolist(),
            "features": self.feature_description,
        }
        for method, labels in self.labels.items():
            mis = count_misclustered(labels, self.class_index)
            out[method] = {
                "n_clusters": int(self.n_clusters[method]),
                "misclustered": mis,
                "misclustered_fraction": mis / self.n_demos,
                "ari": float(adjusted_rand_score(self.class_index, labels)),
                "composition": composition(labels, self.class_index, len(self.classes)).tolist(),
                "method": self.method_description[method],
            }
        out["timing"] = {k: round(float(v), 6) for k, v in self.timing.items()}
        return out


def _check_classes(classes) -> list:
    if isinstance(classes, str):
        classes = [c for c in classes.split(",") if c.strip()]
    try:
        names = [str(c).strip().lower() for c in classes]
    except TypeError:
        raise ValueError(f"classes: expected a list of class names, got {classes!r}") from None
    unknown = [c for c in names if c not in _KNOWN]
    if unknown:
        raise ValueError(f"classes: expected names among {list(_KNOWN)}, got {unknown}")
    if len(names) < 2 or len(set(names)) != len(names):
        raise ValueError(f"classes: expected at least two different classes, got {names}")
    return names


def _rail_folder(data_dir) -> Path:
    """Accept the RAIL folder itself or the shared data folder holding ``rail/``."""
    root = Path(data_dir)
    if not root.is_dir():
        raise ValueError(f"data_dir: expected a folder holding the RAIL dataset, got {str(root)!r} "
                         "which is not a directory")
    subdirs = {d.name.lower() for d in root.iterdir() if d.is_dir()}
    if not subdirs & set(_KNOWN) and (root / "rail").is_dir():
        return root / "rail"
    return root


def _paper_features(folder, demos_by_class, classes):
    """Angular similarity to the paper's representatives, min-max normalised per column."""
    reps = []
    for name, index in PAPER_REPRESENTATIVES.items():
        demos = demos_by_class.get(name)
        if demos is None:  # the representative's class is not clustered: load it anyway
            demos = load_rail(folder, classes=[name], order="authors")
        if index >= len(demos):
            raise ValueError(f"data_dir: expected at least {index + 1} {name} demos for the paper's "
                             f"representative #{index}, found {len(demos)}")
        reps.append(demos[index]["position"])
    trajs = [d["position"] for c in classes for d in demos_by_class[c]]
    raw = AngularSimilarityFeatures(representatives=reps).fit_transform(trajs)
    return raw, minmax_scale(raw)  # per column; a constant column maps to 0


def rail_experiment(data_dir, *, mode: str = "default", classes=("reaching", "pushing", "writing"),
                    random_state=0) -> RailExperimentResult:
    """Run the RAIL clustering experiment and keep its arrays (see :func:`run_rail_experiment`).

    Examples
    --------
    >>> result = rail_experiment("data/rail", mode="paper")  # doctest: +SKIP
    >>> result.summary()["elastic"]["misclustered"]  # doctest: +SKIP
    20
    """
    if mode not in _MODES:
        raise ValueError(f"mode: expected one of {list(_MODES)}, got {mode!r}")
    names = _check_classes(classes)
    if not (random_state is None or (isinstance(random_state, (int, np.integer)) and not isinstance(
            random_state, bool) and 0 <= random_state <= 2 ** 32 - 1)):
        raise ValueError(f"random_state: expected None or an integer in [0, 2^32 - 1] (--seed), got "
                         f"{random_state!r}")
    folder = _rail_folder(data_dir)
    timing = {}
    start = time.perf_counter()
    demos_by_class = {c: load_rail(folder, classes=[c], order="authors") for c in names}
    timing["load_s"] = time.perf_counter() - start
    demos = [d for c in names for d in demos_by_class[c]]
    class_index = np.repeat(np.arange(len(names)), [len(demos_by_class[c]) for c in names])
    trajectories = [d["position"] for d in demos]

    tic = time.perf_counter()
    if mode == "paper":
        raw, features = _paper_features(folder, demos_by_class, names)
        agg_input = raw  # the authors run Ward on the un-normalised features
        feature_text = ("angular similarity to reaching #28, pushing #29, writing #0 (authors' order), "
                        "min-max normalised per column for elastic clustering")
        elastic = ElasticClustering(stretch=1.2, criterion="paper", random_state=random_state)
    else:
        featuriser = HeadingFeatures(random_state=random_state)
        features = agg_input = featuriser.fit_transform(demos)
        feature_text = (f"HeadingFeatures(n_points={featuriser.n_points}, n_components="
                        f"{featuriser.n_components}): unit step directions over time in each demo's "
                        "heading frame, PCA; no labels or representatives")
        elastic = ElasticClustering(random_state=random_state)
    timing["features_s"] = time.perf_counter() - tic

    tic = time.perf_counter()
    elastic.fit(features)
    timing["elastic_s"] = time.perf_counter() - tic
    # Paper: the number of classes, as the authors set it; default: no labels, so the
    # number the elastic map found on its own.
    n_agg = len(names) if mode == "paper" else elastic.n_clusters_
    tic = time.perf_counter()
    if n_agg > 1:
        agg_labels = AgglomerativeClustering(n_clusters=n_agg, linkage="ward").fit_predict(agg_input)
    else:
        agg_labels = np.zeros(len(demos), dtype=np.intp)
    timing["agglomerative_s"] = time.perf_counter() - tic
    timing["total_s"] = time.perf_counter() - start

    methods = {
        "elastic": (f"ElasticClustering(stretch={elastic.stretch}, criterion={elastic.criterion!r}), "
                    "number of clusters found automatically"),
        "agglomerative": (f"AgglomerativeClustering(ward, n_clusters={n_agg}) on "
                          + ("un-normalised features, n_clusters = number of classes as in the paper"
                             if mode == "paper" else
                             "the same features, n_clusters taken from elastic clustering (no labels)")),
    }
    return RailExperimentResult(
        mode=mode, classes=names, class_index=class_index, trajectories=trajectories,
        features=np.asarray(features), labels={"elastic": elastic.labels_, "agglomerative": agg_labels},
        n_clusters={"elastic": elastic.n_clusters_, "agglomerative": n_agg},
        feature_description=feature_text, method_description=methods, timing=timing,
    )


def run_rail_experiment(data_dir, *, mode: str = "default", classes=("reaching", "pushing", "writing"),
                        random_state=0) -> dict:
    """Cluster RAIL demonstrations with elastic and agglomerative clustering and score them.

    Parameters
    ----------
    data_dir : str or path-like
        The RAIL folder (with ``REACHING/`` ...) or the data folder holding ``rail/``.
    mode : {"default", "paper"}, default="default"
        ``"paper"`` reproduces the paper's Fig. 4 exactly: users in the
        authors' order, angular similarity to reaching #28, pushing #29 and
        writing #0, min-max normalised, ``ElasticClustering(stretch=1.2,
        criterion="paper")``; Ward agglomerative clustering with as many
        clusters as classes on the un-normalised features.
        ``"default"`` uses no labels at all: :class:`HeadingFeatures`
        (direction over time in each demo's own heading frame), elastic
        clustering with its default automatic criterion, and Ward with the
        number of clusters the elastic map found.
    classes : sequence of str or comma-separated str, default=("reaching", "pushing", "writing")
        Among reaching, pushing, pressing, writing.
    random_state : int, RandomState instance or None, default=0
        For the first elastic node and the PCA.

    Returns
    -------
    dict
        ``mode``, ``classes``, ``n_demos``, ``class_counts``, ``features``; for
        ``"elastic"`` and ``"agglomerative"``: ``n_clusters``,
        ``misclustered`` (demos whose class is not their cluster's majority),
        ``misclustered_fraction``, ``ari`` (adjusted Rand index),
        ``composition`` (clusters x classes counts) and ``method``; ``timing``
        in seconds (loading included in ``total_s``).

    Raises
    ------
    ValueError
        For an unknown mode or class, or a folder without the RAIL data.

    Examples
    --------
    >>> out = run_rail_experiment("data/rail", mode="paper")  # doctest: +SKIP
    >>> out["elastic"]["composition"], out["agglomerative"]["misclustered"]  # doctest: +SKIP
    ([[60, 20, 0], [0, 40, 0], [0, 0, 30]], 22)
    """
    return rail_experiment(data_dir, mode=mode, classes=classes, random_state=random_state).summary()


def plot_rail_experiment(result, path) -> Path:
    """The RAIL figure: ground truth, elastic and agglomerative clusters, features and trajectories.

    Parameters
    ----------
    result : RailExperimentResult
        From :func:`skillbank.experiments.rail_experiment`.
    path : str or path-like

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> plot_rail_experiment(rail_experiment("data/rail", mode="paper"), "rail.png")  # doctest: +SKIP
    PosixPath('rail.png')
    """
    if not isinstance(result, RailExperimentResult):
        raise ValueError(f"result: expected a RailExperimentResult, got {type(result).__name__}")
    summary = result.summary()
    labelings = {
        f"{m} ({summary[m]['misclustered']} misclustered)": result.labels[m] for m in result.labels
    }
    return plot_cluster_comparison(
        result.features, labelings, path, trajectories=result.trajectories,
        classes=result.class_index, class_names=[c.capitalize() for c in result.classes],
        max_clusters_shown=max(len(result.classes), 3),
        title=f"RAIL clustering, {result.mode} mode ({result.n_demos} demonstrations)", unit="m",
    )
