"""Scene files with a world (issue 24): table, workspace, transit, object shapes; each bad value one line."""

from __future__ import annotations

import numpy as np
import pytest

from skillbank.core import Box
from skillbank.planning import plan_task, scene_from_dict
from skillbank.planning._scene import BUTTON_SIZE, BUTTON_TRAVEL, TABLE_HALF_EXTENT, TABLE_THICKNESS

from .conftest import BUTTONS_DOC, button_scene

BASE = button_scene([[0.1, -0.5, 0.15]], goal=["b1"], start=[0.0, -0.45, 0.4])


def _with(**change):
    doc = {**BASE, **change}
    return doc


def test_a_table_by_height_spans_the_workspace_or_the_default_extent():
    s = scene_from_dict(_with(table={"height": 0.05}))
    assert s.table == Box([-TABLE_HALF_EXTENT, -TABLE_HALF_EXTENT, 0.05 - TABLE_THICKNESS],
                          [TABLE_HALF_EXTENT, TABLE_HALF_EXTENT, 0.05])
    s = scene_from_dict(_with(table={"height": 0.0}, workspace={"lower": [-0.8, -0.9, -0.1],
                                                               "upper": [0.7, 0.6, 1.0]}))
    assert s.table == Box([-0.8, -0.9, -TABLE_THICKNESS], [0.7, 0.6, 0.0])
    np.testing.assert_array_equal(s.workspace[0], [-0.8, -0.9, -0.1])
    s = scene_from_dict(_with(table={"box": [-1, -1, -0.2, 1, 1, 0.1]}, transit={"height": 0.3}))
    assert s.table == Box([-1, -1, -0.2], [1, 1, 0.1]) and s.transit == 0.3


def test_objects_get_shapes_and_a_button_without_one_is_a_default_button():
    doc = _with(objects={
        "b1": {"type": "button", "position": [0.1, -0.5, 0.15]},
        "b2": {"type": "button", "position": [0.2, -0.5, 0.15], "size": [0.01], "travel": 0.002},
        "crate": {"type": "box", "shape": "box", "position": [0, -0.6, 0.1], "size": [0.1, 0.2, 0.05],
                  "mass": 0.4, "friction": 0.8},
        "can": {"type": "thing", "shape": "cylinder", "position": [0, -0.7, 0.1], "size": [0.03, 0.1]},
        "ball": {"type": "thing", "shape": "sphere", "position": [0, -0.8, 0.1], "size": [0.02]},
        "idea": {"type": "button"}})
    objs = scene_from_dict(doc).objects
    assert (objs["b1"].shape, objs["b1"].size.tolist(), objs["b1"].travel) == \
        ("button", list(BUTTON_SIZE), BUTTON_TRAVEL)
    assert (objs["b2"].size.tolist(), objs["b2"].travel) == ([0.01], 0.002)
    assert (objs["crate"].shape, objs["crate"].size.tolist(), objs["crate"].mass, objs["crate"].friction) == \
        ("box", [0.1, 0.2, 0.05], 0.4, 0.8)
    assert objs["can"].mass is None and objs["ball"].size.tolist() == [0.02]
    assert objs["idea"].shape is None  # no position: not in the world


@pytest.mark.parametrize("change, message", [
    ({"table": {"height": 0.5}}, r"^table: expected its top below the start's tool point, got the top at z = "
                                 r"0\.5 m above start\.position z = 0\.4 m$"),
    ({"table": {"height": 0.2}}, r"^objects\['b1'\]\.position: expected a point on or above the table top "
                                 r"\(z = 0\.2 m\), got z = 0\.15 m$"),
    ({"table": {"height": 0, "box": [0, 0, 0, 1, 1, 1]}}, r"^table: expected \{\"height\": z\} or \{\"box\": "
                                                          r"\[x0, y0, z0, x1, y1, z1\]\}, got both$"),
    ({"table": 0.0}, r"^table: expected \{\"height\": z\} .*got the number 0\.0$"),
    ({"table": {"top": 0.0}}, r"^table: unknown key 'top'; expected keys among \['height', 'box'\]$"),
    ({"table": {"height": True}}, r"^table\.height: expected a number, got true$"),
    ({"table": {"box": [0, 0, 0, 1, 1, 0]}}, r"^table\.box: expected x0 < x1, y0 < y1 and z0 < z1, got z: "
                                             r"0 >= 0$"),
    ({"table": {"box": [0, 0, 0, 1, 1]}}, r"^table\.box: expected 6 numbers, got 5$"),
    ({"workspace": {"lower": [0, 0, 0], "upper": [1, 1, 0]}},
     r"^workspace: expected lower < upper on every axis, got z: lower 0 >= upper 0$"),
    ({"workspace": {"lower": [0, 0, 0]}}, r"^workspace\.upper: expected a corner \[x, y, z\], got none$"),
    ({"workspace": {"lower": [0, 0, 0], "upper": [1, 1, 1], "margin": 1}},
     r"^workspace: unknown key 'margin'"),
    ({"workspace": {"lower": [-1, -0.48, 0], "upper": [1, 0, 1]}},
     r"^objects\['b1'\]\.position: expected a point inside the workspace, got y = -0\.5 outside "
     r"\[-0\.48, 0\]$"),
    ({"workspace": {"lower": [-1, -1, 0], "upper": [1, 1, 0.3]}},
     r"^start\.position: expected a point inside the workspace, got z = 0\.4 outside \[0, 0\.3\]$"),
    ({"transit": 0.3}, r"^transit: expected \{\"height\": z\} \(metres\), got the number 0\.3$"),
    ({"transit": {"height": 0.0}, "table": {"height": 0.1}},
     r"^transit\.height: expected a height above the table top \(z = 0\.1 m\), got 0 m$"),
    ({"transit": {"height": 2.0}, "workspace": {"lower": [-1, -1, 0], "upper": [1, 1, 1]}},
     r"^transit\.height: expected a height inside the workspace \(z in \[0, 1\]\), got 2 m$"),
])
def test_a_bad_world_is_one_line_naming_its_key(change, message):
    with pytest.raises(ValueError, match=message):
        scene_from_dict(_with(**change))


def _obj(**keys):
    return _with(objects={"b1": {"type": "button", "position": [0.1, -0.5, 0.15], **keys}})


@pytest.mark.parametrize("keys, message", [
    ({"size": [-0.02]}, r"^objects\['b1'\]\.size\[0\]: expected a positive number \(metres\), got the number "
                        r"-0\.02$"),
    ({"size": [0]}, r"^objects\['b1'\]\.size\[0\]: expected a positive number \(metres\), got the number 0$"),
    ({"size": [0.02, 0.01]}, r"^objects\['b1'\]\.size: expected a button's \[radius\] \(1 number\(s\), "
                             r"metres\), got 2 number\(s\)$"),
    ({"shape": "box", "size": [0.1, 0.1]}, r"^objects\['b1'\]\.size: expected a box's \[x, y, z\] \(3 "
                                           r"number\(s\), metres\), got 2 number\(s\)$"),
    ({"shape": "cylinder", "size": [0.1]},
     r"^objects\['b1'\]\.size: expected a cylinder's \[radius, height\]"),
    ({"shape": "sphere"}, r"^objects\['b1'\]\.size: expected a sphere's \[radius\] \(metres\), got none$"),
    ({"shape": "box", "size": [0.1, 0.1, 0.1], "travel": 0.01},
     r"^objects\['b1'\]\.travel: expected travel on a button only \(how far its cap moves\), got it on a "
     r"box$"),
    ({"travel": -0.004}, r"^objects\['b1'\]\.travel: expected a positive number \(metres\)"),
    ({"mass": 0.1}, r"^objects\['b1'\]\.mass: expected mass on a movable body \(box, cylinder, sphere\), got "
                    r"it on a button, which is fixed$"),
    ({"shape": "box", "size": [0.1, 0.1, 0.1], "mass": 0}, r"^objects\['b1'\]\.mass: expected a positive "
                                                           r"number \(kilograms\), got the number 0$"),
    ({"shape": "cone"}, r"^objects\['b1'\]\.shape: expected one of \['button', 'box', 'cylinder', "
                        r"'sphere'\], got the string 'cone'$"),
    ({"friction": "high"}, r"^objects\['b1'\]\.friction: expected a number, got the string 'high'$"),
    ({"colour": "red"}, r"^objects\['b1'\]: unknown key 'colour'; expected keys among \['type', 'position'"),
])
def test_a_bad_object_shape_is_one_line_naming_its_key(keys, message):
    with pytest.raises(ValueError, match=message):
        scene_from_dict(_obj(**keys))


def test_physical_keys_need_a_shape_and_a_shape_needs_a_position():
    doc = _with(objects={"b1": {"type": "lever", "position": [0, -0.5, 0.1], "size": [0.02]}})
    with pytest.raises(ValueError, match=r"^objects\['b1'\]\.size: expected it with a 'shape' \(one of "):
        scene_from_dict(doc)
    doc = _with(objects={"b1": {"type": "lever", "shape": "sphere", "size": [0.02]}})
    with pytest.raises(ValueError, match=r"^objects\['b1'\]\.shape: expected a 'position' with it \(where "
                                         r"the sphere is\), got none$"):
        scene_from_dict(doc)


def test_the_world_lists_the_table_and_a_slab_outside_each_workspace_face():
    s = scene_from_dict(_with(table={"height": 0.0}, obstacles={"wall": "box:0,0,0,0.1,0.1,0.1"},
                              workspace={"lower": [-1, -1, -0.1], "upper": [1, 1, 1]}))
    world = s.world()
    labels = [label for label, _ in world]
    assert labels[:2] == ["obstacle wall (box:0,0,0,0.1,0.1,0.1)", "the table (top at z = 0 m)"]
    assert labels[2:] == [f"the workspace's bound {a} {op} {v:g} m" for a, lo, hi in
                          zip("xyz", (-1, -1, -0.1), (1, 1, 1), strict=True)
                          for op, v in ((">=", lo), ("<=", hi))]
    slabs = [ob for _, ob in world[2:]]
    inside, outside = np.array([[0.99, -0.99, 0.99]]), np.array([[1.01, 0, 0.5], [0, 0, -0.11], [0, 0, 1.02]])
    assert not any(ob.collides(inside) for ob in slabs)
    assert all(any(ob.signed_distance(p)[0] < 0 for ob in slabs) for p in outside)
    # a path leaving through a corner crosses a slab
    assert any(ob.collides(np.array([[0.9, 0.9, 0.9], [1.5, 1.5, 1.5], [0.9, 0.9, 0.9]])) for ob in slabs)


def test_every_scene_written_before_the_world_still_reads_and_plans(described_library):
    s = scene_from_dict(BUTTONS_DOC)
    assert s.table is None and s.workspace is None and s.transit is None
    assert [label for label, _ in s.world()] == []
    res = plan_task(described_library.store, s)
    assert [seg["kind"] for step in res.steps for seg in step.segments] == ["primitive", "primitive"]


def test_a_type_no_action_takes_is_named_when_no_plan_is_found(described_library):
    doc = button_scene([[0.2, 0.0, 0.0], [0.2, 0.2, 0.0]], goal=["b2"])
    doc["objects"]["b2"]["type"] = "switch"
    with pytest.raises(ValueError, match=r"^goal: no plan reaches \(pressed b2\): no sequence of the "
                                         r"skills' actions makes it true from the initial facts; type "
                                         r"'switch' of the scene's objects b2 is the type of no action's "
                                         r"parameter \(the actions take button\)$"):
        plan_task(described_library.store, scene_from_dict(doc))
