"""The seams of the SQL written once for both backends (skillbank.store._sql): the parameter markers each
driver gets, and the id counters each backend keeps behind the shared inserts."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank import Demonstration
from skillbank.store import open_store
from skillbank.store._sql import translate


@pytest.mark.parametrize("sql, marker, expected", [
    ("SELECT a FROM t WHERE b = ? AND c IN (?, ?)", "%s", "SELECT a FROM t WHERE b = %s AND c IN (%s, %s)"),
    ("SELECT a FROM t WHERE b = ? AND c IN (?, ?)", "?", "SELECT a FROM t WHERE b = ? AND c IN (?, ?)"),
    # a '?' in a literal is text, not a marker; psycopg reads a literal '%' as the start of a marker
    ("UPDATE t SET s = 'why?' WHERE k = ?", "%s", "UPDATE t SET s = 'why?' WHERE k = %s"),
    ("SELECT ? WHERE s LIKE '50%' AND p = ?", "%s", "SELECT %s WHERE s LIKE '50%%' AND p = %s"),
    ("SELECT 'it''s?', ?", "%s", "SELECT 'it''s?', %s"),  # an escaped quote keeps the literal open
    ("SELECT 'it''s?', ?", "$", "SELECT 'it''s?', $"),
])
def test_the_shared_sql_gets_each_drivers_markers(sql, marker, expected):
    assert translate(sql, marker) == expected


def _demo(seed=0, n=30):
    rng = np.random.default_rng(seed)
    return Demonstration(np.cumsum(rng.uniform(0.01, 0.02, n)), {"position": rng.normal(size=(n, 2))}, {})


@pytest.fixture(params=["sqlite", "postgresql"])
def location(request, tmp_path):
    return str(tmp_path / "ids.db") if request.param == "sqlite" else request.getfixturevalue("postgres_url")


def test_ids_come_from_the_counters_and_are_never_reused(location):
    with open_store(location) as store:
        assert store.add_demonstrations([{"demo": _demo(0), "bounds": [(0, 10), (10, 30)]},
                                         {"demo": _demo(1), "bounds": [(0, 30)]}]) == [(1, [1, 2]), (2, [3])]
        store.remove_demonstration(2)
        assert store.add_demonstration(_demo(2), [(0, 30)]) == (3, [4])
        v = store.add_version(params={}, centers=np.zeros((1, 2)), pca_mean=np.zeros(2),
                              pca_components=np.eye(2), members=[(4, 0, np.zeros(2))])
        assert v == 1 and store.members(np.int64(v)) == {4: 0}  # a numpy version too, on both
        assert store.add_version(params={}, centers=np.zeros((1, 2)), pca_mean=np.zeros(2),
                                 pca_components=np.eye(2), members=[]) == 2


def test_a_sqlite_counter_behind_its_ids_continues_past_them_as_autoincrement_does(tmp_path):
    path = tmp_path / "behind.db"
    with open_store(path) as store:
        store.add_demonstration(_demo(0), [(0, 10), (10, 30)])
        # a counter set behind the ids (by hand): SQLite's AUTOINCREMENT would still pick max(id) + 1
        store.conn.execute("UPDATE sqlite_sequence SET seq = 0")
        assert store.add_demonstration(_demo(1), [(0, 30)]) == (2, [3])
        assert dict(store.conn.execute("SELECT name, seq FROM sqlite_sequence WHERE name IN "
                                       "('demonstrations', 'primitives')").fetchall()) == \
            {"demonstrations": 2, "primitives": 3}
