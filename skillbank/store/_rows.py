"""What every stored row must hold: one validator for ``library import``, ``library copy`` and export.

An import checks the records it read from an export folder, a copy (and an
export) the records it read from the source library, with the same
functions, before anything is written: a record that passes can be stored
and later work (``library add``, ``cluster``, ``reuse``) can continue from it.

- ids (demonstrations, primitives, clustering versions, description
  revisions) are integers in ``1..MAX_ID`` (2^53 - 1): every store holds
  them (SQLite's and PostgreSQL's 64-bit integers), JSON readers in any
  language read them exactly, and a later add has 2^63 - 2^53 ids left to
  number from;
- a demonstration's stored sample count equals its ``t``; its primitives
  lie inside it (``0 <= start < stop <= n_steps``) and have unique ids;
- a clustering version's parameters are those a later add and recluster can
  use (``features`` a kind :mod:`skillbank.clustering` knows, ``n_points``
  in ``2..MAX_N_POINTS``, ``n_components`` and ``n_dims`` positive,
  ``stretch`` finite and positive, ``random_state`` null or in
  ``0..2^32 - 1``); its arrays have the shapes its ``n_clusters`` declares,
  hold finite values, and its members name stored primitives and clusters.

Messages start with ``where`` (a manifest entry, or the library and its
row) and never quote stored bytes.
"""

from __future__ import annotations

import numpy as np

from ..core._defaults import FEATURE_KINDS  # not skillbank.clustering: it imports scikit-learn

__all__ = ["MAX_ID", "MAX_N_POINTS", "ASSIGNED", "check_row_id", "check_demonstration_record",
           "check_version_params", "check_version_record", "damaged"]

#: Largest id a library holds: 2^53 - 1 (exact in every JSON reader; a later add numbers on from it).
MAX_ID = 2 ** 53 - 1
#: Most samples a clustering version may resample each primitive to (``n_points``): features of
#: 10,000 points of 3-D positions are 240 kB a primitive; the default is 16.
MAX_N_POINTS = 10_000
#: How a member joined its cluster.
ASSIGNED = ("fit", "incremental")
_MAX_SEED = 2 ** 32 - 1  # what numpy's and scikit-learn's random_state take


def damaged(location: str, row: str, what: str, remedy: str = "") -> ValueError:
    """The one-line error for a damaged library: which library, which row, what is wrong, what to do.

    Examples
    --------
    >>> str(damaged("lib.db", "demonstration 3", "expected .npy bytes, got NULL"))
    "library 'lib.db' is damaged: demonstration 3: expected .npy bytes, got NULL; restore it from a backup"
    """
    remedy = remedy or "restore it from a backup"
    return ValueError(f"library {location!r} is damaged: {row}: {what}; {remedy}")


def _int(value) -> int | None:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        return None
    return int(value)


def check_row_id(value, where: str, what: str = "an id") -> int:
    """``value`` as an int in ``1..MAX_ID``, else ValueError starting with ``where``.

    Examples
    --------
    >>> check_row_id(2 ** 63 - 1, "id")
    Traceback (most recent call last):
    ...
    ValueError: id: expected an id in 1..9007199254740991 (2^53 - 1), got 9223372036854775807
    """
    n = _int(value)
    if n is None or not 1 <= n <= MAX_ID:
        raise ValueError(f"{where}: expected {what} in 1..{MAX_ID} (2^53 - 1), got {value!r}"[:300])
    return n


def check_demonstration_record(record: dict, where: str, *, n_steps=None) -> None:
    """Check a demonstration record (``id``, ``demo``, ``primitives``) before it is stored.

    ``n_steps``, when given, is the sample count the source stored for it
    (a copy's row), which must equal its ``t``'s.
    """
    check_row_id(record["id"], f"{where} id")
    demo = record["demo"]
    if n_steps is not None and _int(n_steps) != demo.n_steps:
        raise ValueError(f"{where}: expected n_steps {demo.n_steps} (the samples of its t), "
                         f"got {n_steps!r}"[:300])
    seen = set()
    for p in record["primitives"]:
        pid = check_row_id(p["id"], f"{where} primitive id")
        a, b = _int(p["start"]), _int(p["stop"])
        if a is None or b is None or not 0 <= a < b <= demo.n_steps:
            raise ValueError(f"{where} primitive {pid}: expected 0 <= start < stop <= {demo.n_steps} (the "
                             f"samples of demonstration {record['id']}), got start {p['start']!r}, "
                             f"stop {p['stop']!r}"[:300])
        if pid in seen:
            raise ValueError(f"{where} primitive {pid}: expected a unique primitive id, got it twice")
        seen.add(pid)


def check_version_params(params, where: str) -> None:
    """Check the parameters of a clustering version that a later add or recluster uses.

    Examples
    --------
    >>> check_version_params({"features": "default", "n_points": 10 ** 12}, "params")
    Traceback (most recent call last):
    ...
    ValueError: params.n_points: expected an integer in 2..10000 (the store's MAX_N_POINTS), got 1000000000000
    """
    if not isinstance(params, dict):
        raise ValueError(f"{where}: expected an object, got {type(params).__name__}")
    if params.get("features") not in FEATURE_KINDS:
        raise ValueError(f"{where}.features: expected one of {list(FEATURE_KINDS)}, "
                         f"got {params.get('features')!r}"[:300])
    n = _int(params.get("n_points"))
    if n is None or not 2 <= n <= MAX_N_POINTS:
        raise ValueError(f"{where}.n_points: expected an integer in 2..{MAX_N_POINTS} "
                         f"(the store's MAX_N_POINTS), got {params.get('n_points')!r}"[:300])
    for key in ("n_components", "n_dims"):
        if key in params and (_int(params[key]) is None or not 1 <= _int(params[key]) <= MAX_N_POINTS * 64):
            raise ValueError(f"{where}.{key}: expected a positive integer, got {params[key]!r}"[:300])
    stretch = params.get("stretch")
    if stretch is not None and (isinstance(stretch, bool) or not isinstance(stretch, (int, float))
                                or not np.isfinite(stretch) or not stretch > 0):
        raise ValueError(f"{where}.stretch: expected a finite number > 0, got {stretch!r}"[:300])
    seed = params.get("random_state")
    if seed is not None and (_int(seed) is None or not 0 <= _int(seed) <= _MAX_SEED):
        raise ValueError(f"{where}.random_state: expected null or an integer in 0..{_MAX_SEED}, "
                         f"got {seed!r}"[:300])


def _finite(a, name: str, where: str) -> np.ndarray:
    a = np.asarray(a)
    if a.dtype.kind not in "iuf":
        raise ValueError(f"{where}: expected {name!r} as numbers, got a {a.dtype.kind}-kind array")
    if a.size and not np.isfinite(a).all():
        raise ValueError(f"{where}: expected {name!r} to hold finite values, got NaN or infinity")
    return a


def check_version_record(record: dict, primitives, where: str) -> None:
    """Check a clustering version record (``version``, ``params``, ``n_clusters``, ``labels``, ``arrays``).

    ``primitives`` holds the ids of the primitives stored with it: every
    member must name one of them.
    """
    check_row_id(record["version"], f"{where} version")
    check_version_params(record["params"], f"{where} params")
    n = _int(record["n_clusters"])
    if n is None or not 1 <= n <= 2 ** 31:
        raise ValueError(f"{where}: expected n_clusters in 1..{2 ** 31}, got {record['n_clusters']!r}"[:300])
    a = record["arrays"]
    centers, mean, comps = (_finite(a[k], k, where) for k in ("centers", "pca_mean", "pca_components"))
    d = comps.shape[0] if comps.ndim == 2 else 0
    if centers.shape != (n, d) or comps.ndim != 2 or mean.shape != (comps.shape[1],) or d == 0:
        raise ValueError(f"{where}: expected centers ({n}, d), pca_components (d, f) and pca_mean (f,) with "
                         f"d >= 1, got shapes {centers.shape}, {comps.shape} and {mean.shape}")
    ids, clusters, assigned = a["member_ids"], a["member_clusters"], a["member_assigned"]
    features = a["member_features"]
    if not len(ids) == len(clusters) == len(assigned) == len(features):
        raise ValueError(f"{where}: expected one cluster, feature row and assignment per member, got "
                         f"{len(ids)} members, {len(clusters)}, {len(features)} and {len(assigned)}")
    widths = {np.shape(f) for f in features}
    if widths - {(d,)}:
        raise ValueError(f"{where}: expected member_features of shape {(len(ids), d)}, got rows of shape "
                         f"{sorted(widths - {(d,)})[0]}")
    for k, f in enumerate(features):
        _finite(f, f"member_features[{k}]", where)
    for name, expected, bad in (
            ("member_ids", "ids of primitives stored with it", [i for i in ids if _int(i) not in primitives]),
            ("member_clusters", f"clusters in 0..{n - 1}",
             [c for c in clusters if _int(c) is None or not 0 <= _int(c) < n]),
            ("member_assigned", f"values in {list(ASSIGNED)}", [s for s in assigned if s not in ASSIGNED])):
        if bad:  # a bad member_assigned string is stored content: counted, not quoted
            first = f" (first {bad[0]})" if name != "member_assigned" else ""
            raise ValueError(f"{where}: expected {name} to hold {expected}, got {len(bad)} that do "
                             f"not{first}")
    if len(set(map(int, ids))) != len(ids):
        raise ValueError(f"{where}: expected member_ids to be unique, got a primitive twice")
    for c, _ in record["labels"]:
        if _int(c) is None or not 0 <= _int(c) < n:
            raise ValueError(f"{where}: expected labels of clusters in 0..{n - 1}, got one of cluster {c!r}")
