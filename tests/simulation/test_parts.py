"""One demonstration of several objects is one part per object: its reach, its carry and what follows."""

from types import SimpleNamespace

import numpy as np

from skillbank.selection import Relation
from skillbank.simulation._evaluate import _parts, _Segment, _Source, driven_robot


def _seg(i, obj=None, carried=False, target=None):
    relation = None if obj is None else Relation(obj, carried, 0.01, np.zeros(3), None, target=target)
    return _Segment(SimpleNamespace(id=i, start=10 * i, stop=10 * i + 10), relation, ("world",))


def _source(*segments, objects=("Bread", "Can", "Milk")):
    return _Source(7, {o: np.zeros(3) for o in objects}, np.zeros((10 * len(segments), 7)), list(segments),
                   robot="Panda")


def test_a_demonstration_of_three_objects_is_three_parts():
    src = _source(_seg(0, "Milk"), _seg(1, "Milk", True), _seg(2, "Bread"), _seg(3, "Bread", True),
                  _seg(4, "Can"), _seg(5, "Can", True, target="Bread"), _seg(6))
    parts = _parts(src)
    assert [[s.primitive.id for s in p.segments] for p in parts] == [[0, 1], [2, 3], [4, 5, 6]]
    # each knows the objects it acts on: the one it carries, and where it puts it
    assert [sorted(p.start) for p in parts] == [["Milk"], ["Bread"], ["Bread", "Can"]]
    assert {p.id for p in parts} == {7} and all(p.actions is src.actions for p in parts)
    # the arm is counted once per demonstration, not per part
    assert driven_robot(parts + [_source(_seg(0, "Milk"), _seg(1, "Milk", True))], "UR5e")["notes"] == \
        ["library recorded on Panda; driven on UR5e"]


def test_pieces_of_one_reach_that_pass_other_objects_stay_one_part():
    # cut by motion alone, a reach's first piece can end nearest another object: nothing was carried yet
    src = _source(_seg(0, "Can"), _seg(1, "Milk"), _seg(2, "Milk", True), _seg(3, "Milk"))
    (part,) = _parts(src)
    assert part is src  # one object moved: the source as it was, every recorded object kept


def test_a_source_that_names_no_object_is_kept_whole():
    src = _source(_seg(0), _seg(1))
    assert _parts(src) == [src]
