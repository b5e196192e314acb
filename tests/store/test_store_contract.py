"""What every store backend must do, tested through the Store interface only.

The ``store`` fixture is parametrised over the registered backends that can be started here, so a
new backend (one class plus one line in ``skillbank.store.STORES``) runs these tests by adding a
factory to ``FACTORIES``. A factory gets the test's ``request`` and may ask it for fixtures (the
PostgreSQL one a fresh database of the session's server, ``tests/store/conftest.py``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.store import STORES, SQLiteStore, Store, open_store


def _sqlite(request) -> Store:
    return open_store(f"sqlite:///{request.getfixturevalue('tmp_path') / 'contract.db'}")


def _postgres(request) -> Store:
    return open_store(request.getfixturevalue("postgres_url"))


#: backend scheme -> factory of a fresh, empty store
FACTORIES = {"sqlite": _sqlite, "postgresql": _postgres}


@pytest.fixture(params=sorted(FACTORIES))
def store(request):
    s = FACTORIES[request.param](request)
    assert isinstance(s, STORES[request.param])
    yield s
    s.close()


def _demo(n=30, seed=0, **meta):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.01, 0.02, n))
    return Demonstration(t, {"position": rng.normal(size=(n, 3)), "gripper": rng.uniform(size=n)},
                         {"user": "a", **meta})


def test_every_backend_is_registered_and_has_a_factory():
    assert set(FACTORIES) == set(STORES)
    for scheme, cls in STORES.items():
        assert cls.scheme == scheme and issubclass(cls, Store)


def test_demonstrations_round_trip_exactly(store):
    demo = _demo(label="x")
    did, pids = store.add_demonstration(demo, [(0, 10), (10, 30)], source="a.h5", label="reach",
                                        provenance={"segment": True, "window": 8})
    assert store.demonstration_ids() == [did] and len(pids) == 2
    back = store.demonstrations([did])[did]
    assert back.stream_names == demo.stream_names and back.metadata == demo.metadata
    np.testing.assert_array_equal(back.t, demo.t)
    for name in demo.stream_names:
        np.testing.assert_array_equal(back[name], demo[name])
    assert store.provenance(did) == {"segment": True, "window": 8}
    prims = store.primitives()
    assert [(p.id, p.start, p.stop, p.label, p.cluster) for p in prims] == [
        (pids[0], 0, 10, "reach", None), (pids[1], 10, 30, "reach", None)]
    np.testing.assert_array_equal(prims[1].demo["position"], demo["position"][10:30])
    assert prims[1].demo.metadata["primitive_id"] == pids[1]
    assert [p.demo for p in store.primitives(load=False)] == [None, None]
    assert [p.id for p in store.primitives(source="a.h5", demonstration=did)] == pids
    assert store.primitives(source="b.h5") == []
    assert store.check() == "ok"


def test_versions_members_and_labels(store):
    ids = [store.add_demonstration(_demo(seed=k), [(0, 30)])[1][0] for k in range(4)]
    assert store.current_version() is None
    X = np.arange(8.0).reshape(4, 2)
    v1 = store.add_version(params={"stretch": 1.2}, centers=np.array([[0.0, 0.0], [5.0, 5.0]]),
                           pca_mean=np.zeros(2), pca_components=np.eye(2),
                           members=[(ids[0], 0, X[0]), (ids[1], 1, X[1]), (ids[2], 1, X[2])],
                           labels={1: "press"})
    assert store.current_version() == v1
    got = store.version(v1)
    assert got["params"] == {"stretch": 1.2} and got["n_clusters"] == 2
    np.testing.assert_array_equal(got["centers"], [[0.0, 0.0], [5.0, 5.0]])
    assert store.members(v1) == {ids[0]: 0, ids[1]: 1, ids[2]: 1}
    assert store.cluster_labels(v1) == {1: "press"}
    assert [p.label for p in store.primitives(label="press")] == ["press", "press"]
    np.testing.assert_array_equal(store.primitives(cluster=1)[1].features, X[2])
    store.add_members(v1, [(ids[3], 0, X[3]), (ids[0], 1, X[0])])  # ids[0] is already a member: kept
    assert store.members(v1) == {ids[0]: 0, ids[1]: 1, ids[2]: 1, ids[3]: 0}
    store.set_label("reach", cluster=0)
    store.set_label("own", primitive=ids[1])  # a primitive's own label overrides its cluster's
    assert {p.id: p.label for p in store.primitives()} == {ids[0]: "reach", ids[1]: "own", ids[2]: "press",
                                                          ids[3]: "reach"}
    store.set_label(None, cluster=0)
    assert store.cluster_labels(v1) == {1: "press"}
    v2 = store.add_version(params={}, centers=np.zeros((1, 2)), pca_mean=np.zeros(2),
                           pca_components=np.eye(2), members=[(i, 0, X[k]) for k, i in enumerate(ids)])
    assert v2 > v1 and store.current_version() == v2
    assert [v["version"] for v in store.versions()] == [v1, v2]


def test_remove_cascades(store):
    did, pids = store.add_demonstration(_demo(), [(0, 15), (15, 30)])
    keep, _ = store.add_demonstration(_demo(seed=1), [(0, 30)])
    v = store.add_version(params={}, centers=np.zeros((1, 2)), pca_mean=np.zeros(2), pca_components=np.eye(2),
                          members=[(p, 0, np.zeros(2)) for p in pids])
    store.remove_demonstration(did)
    assert store.demonstration_ids() == [keep] and store.members(v) == {}
    assert [p.demonstration_id for p in store.primitives()] == [keep]


@pytest.mark.parametrize("call, match", [
    (lambda s: s.remove_demonstration(99), r"demo_id: no demonstration with id 99"),
    (lambda s: s.demonstrations([99]), r"demonstration: no demonstration with id 99"),
    (lambda s: s.provenance(99), r"demo_id: no demonstration with id 99"),
    (lambda s: s.version(3), r"version: no clustering version 3"),
    (lambda s: s.version("x"), r"version: expected an integer id, got 'x'"),
    (lambda s: s.members(1.5), r"version: expected an integer id, got 1\.5"),
    (lambda s: s.cluster_labels(None), r"version: expected an integer id, got None"),
    (lambda s: s.set_label("x", cluster=0), r"cluster: the library has no clusters yet"),
    (lambda s: s.set_label("x", primitive=99), r"primitive: no primitive with id 99"),
    (lambda s: s.set_label("x"), r"label: give exactly one of cluster= or primitive="),
    (lambda s: s.primitives(cluster="a"), r"cluster: expected an integer id, got 'a'"),
])
def test_errors_name_the_argument(store, call, match):
    with pytest.raises(ValueError, match=match):
        call(store)


def test_a_failed_write_leaves_nothing(store):
    store.add_demonstration(_demo(), [(0, 30)])
    bad = _demo(seed=1)
    bad.metadata["handle"] = object()  # not JSON: fails inside the transaction
    with pytest.raises(TypeError):
        store.add_demonstration(bad, [(0, 30)])
    assert len(store.demonstration_ids()) == 1 and len(store.primitives()) == 1


def test_urls_and_paths(tmp_path, monkeypatch):
    absolute = tmp_path / "abs.db"
    with open_store(f"sqlite:///{absolute}") as s:  # sqlite:////abs/path, as SQLAlchemy writes it
        assert isinstance(s, SQLiteStore) and Path(s.location) == absolute
    monkeypatch.chdir(tmp_path)
    with open_store("sqlite:///rel.db") as s:
        assert Path(s.location) == Path("rel.db")
    with open_store(tmp_path / "plain.db") as s:
        assert open_store(s) is s
    with pytest.raises(ValueError, match=r"library: no store backend for ftp://"):
        open_store("ftp://host/lib")
    with pytest.raises(ValueError, match=r"library: expected a path or a URL, got int"):
        open_store(3)
    with pytest.raises(ValueError, match=r"does not exist; create it with 'skillbank library init'"):
        open_store(tmp_path / "missing.db", create=False)


def test_add_demonstrations_writes_a_batch_in_one_transaction(store):
    store.add_demonstration(_demo(), [(0, 30)])
    v = store.add_version(params={}, centers=np.zeros((2, 2)), pca_mean=np.zeros(2), pca_components=np.eye(2),
                          members=[])
    items = [{"demo": _demo(seed=k), "bounds": [(0, 10), (10, 30)], "source": f"s{k}", "label": "x",
              "provenance": {"k": k}} for k in range(3)]
    items[1]["members"] = {"version": v, "clusters": [1, 0], "features": np.eye(2)}
    out = store.add_demonstrations(items)
    assert [did for did, _ in out] == store.demonstration_ids()[1:] and [len(p) for _, p in out] == [2, 2, 2]
    assert store.provenance(out[2][0]) == {"k": 2}
    assert [p.id for p in store.primitives(source="s1")] == out[1][1]
    assert store.members(v) == {out[1][1][0]: 1, out[1][1][1]: 0}
    assert store.add_demonstrations([]) == []
    bad = _demo(seed=9)
    bad.metadata["handle"] = object()  # fails inside the write, after two demonstrations went in
    with pytest.raises(TypeError):
        store.add_demonstrations([items[0], items[2], {"demo": bad, "bounds": [(0, 30)]}])
    assert len(store.demonstration_ids()) == 4 and len(store.primitives()) == 7


@pytest.mark.parametrize("call, match", [
    (lambda s, d: s.add_demonstrations({"demo": d, "bounds": [(0, 30)]}),
     r"^items: expected a list of dicts with 'demo' and 'bounds', got dict"),
    (lambda s, d: s.add_demonstrations([{"demo": d, "bounds": [(0, 31)]}]),
     r"^items\[0\]\['bounds'\]: expected sample ranges \(start, stop\), 0 <= start < stop <= 30, "
     r"got \(0, 31\)"),
    (lambda s, d: s.add_demonstrations([{"demo": d, "bounds": [(0.5, 3)]}]),
     r"^items\[0\]\['bounds'\]: expected a list of integer pairs"),
    (lambda s, d: s.add_demonstrations([{"demo": d, "bounds": [(0, 30)], "colour": 1}]),
     r"^items\[0\]: unknown key\(s\) \['colour'\]"),
    (lambda s, d: s.add_demonstrations([{"demo": d, "bounds": [(0, 30)]}, {"bounds": [(0, 30)]}]),
     r"^items\[1\]\['demo'\]: expected a Demonstration, got NoneType"),
    (lambda s, d: s.add_demonstrations([{"demo": d, "bounds": [(0, 30)],
                                         "members": {"version": 1, "clusters": [0, 1], "features": [[0]]}}]),
     r"^items\[0\]\['members'\]: expected one cluster and one feature row per bound \(1\), got 2 and 1"),
    (lambda s, d: s.add_demonstration(d, [(5, 2)]), r"^bounds: expected sample ranges .* got \(5, 2\)"),
])
def test_batch_errors_name_the_item(store, call, match):
    with pytest.raises(ValueError, match=match):
        call(store, _demo())
    assert store.demonstration_ids() == []


def test_a_sqlite_store_opened_read_only_writes_nothing(tmp_path):
    path = tmp_path / "ro.db"
    with SQLiteStore(path) as s:
        did, pids = s.add_demonstration(_demo(), [(0, 30)])
    before = path.read_bytes()
    with open_store(f"sqlite:///{path}", readonly=True) as s:
        assert isinstance(s, SQLiteStore) and s.readonly and s.demonstration_ids() == [did]
        for write, what in [
            (lambda: s.add_demonstration(_demo(), [(0, 30)]), "add demonstrations"),
            (lambda: s.remove_demonstration(did), "remove a demonstration"),
            (lambda: s.set_label("x", primitive=pids[0]), "label"),
            (lambda: s.add_members(1, []), "assign primitives to clusters"),
            (lambda: s.add_version(params={}, centers=np.zeros((1, 2)), pca_mean=np.zeros(2),
                                   pca_components=np.eye(2), members=[]), "record a clustering"),
        ]:
            with pytest.raises(ValueError, match=rf"^library '.*ro\.db' is open read-only: cannot {what}$"):
                write()
    assert path.read_bytes() == before
    with SQLiteStore(path) as s:
        assert s.readonly is False
