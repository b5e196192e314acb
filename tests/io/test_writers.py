"""CSV, NPZ and JSON: round trips and malformed files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from skillbank import Demonstration
from skillbank.core._validation import MAX_MAGNITUDE
from skillbank.io import read_csv, read_npz, to_jsonable, write_csv, write_json, write_npz


def _demo(n=12, seed=0, **metadata):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.001, 0.1, n))
    return Demonstration(
        t, {"position": rng.normal(size=(n, 3)), "gripper": rng.uniform(size=n)}, metadata
    )


# ----------------------------------------------------------------------- CSV


def test_csv_round_trip_is_exact(tmp_path):
    demo = _demo()
    path = write_csv(demo, tmp_path / "d.csv")
    assert path == tmp_path / "d.csv"
    assert path.read_text().splitlines()[0] == "t,position_0,position_1,position_2"
    back = read_csv(path)
    np.testing.assert_array_equal(back.t, demo.t)
    np.testing.assert_array_equal(back["position"], demo["position"])
    assert back.metadata == {
        "source": str(path), "format": "csv", "columns": ["position_0", "position_1", "position_2"],
    }


def test_csv_stream_choice(tmp_path):
    demo = _demo()
    path = write_csv(demo, tmp_path / "g.csv", stream="gripper")
    assert path.read_text().splitlines()[0] == "t,gripper_0"
    np.testing.assert_array_equal(read_csv(path)["position"], demo["gripper"])
    only_force = Demonstration(demo.t, {"force": demo["position"]})
    assert write_csv(only_force, tmp_path / "f.csv").read_text().startswith("t,force_0,")
    with pytest.raises(ValueError, match=r"stream: expected one of \['position', 'gripper'\]"):
        write_csv(demo, tmp_path / "x.csv", stream="torque")
    with pytest.raises(TypeError, match="expected a Demonstration"):
        write_csv(np.zeros((3, 2)), tmp_path / "x.csv")


def test_csv_hand_written_file(tmp_path):
    path = tmp_path / "hand.csv"
    path.write_text("t, x, y\n0, 1.5, 2\n0.5, 2.5, 3\n\n")
    demo = read_csv(path)
    np.testing.assert_array_equal(demo["position"], [[1.5, 2.0], [2.5, 3.0]])
    assert demo.metadata["columns"] == ["x", "y"]


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("", "found an empty file"),
        ("\n\n", "found an empty file"),
        ("0,1,2\n1,2,3\n", r"line 1: expected a header row starting with 't', found '0,1,2'"),
        ("t\n0\n1\n", "at least one data column"),
        ("t,x\n", "at least one data row"),
        ("t,x,y\n0,1,2\n1,abc,3\n", r"line 3, column 2: expected a number, found 'abc'"),
        ("t,x,y\n0,1,2\n1,2\n", r"line 3: expected 3 values as in the header, found 2"),
        ("t,x,y\n0,1,2\n1,2,3,4\n", r"line 3: expected 3 values as in the header, found 4"),
        ("t,x\n0,1\n0,2\n", "strictly increasing"),
        ("t,x\n0,1\n1,nan\n", "finite values"),
    ],
)
def test_csv_malformed(tmp_path, raises_format_error, text, reason):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with raises_format_error(path, reason):
        read_csv(path)


def test_csv_binary_file(tmp_path, raises_format_error):
    path = tmp_path / "bin.csv"
    path.write_bytes(b"\xff\xfe\x00\x01garbage")
    with raises_format_error(path, "expected a UTF-8 text file"):
        read_csv(path)


# ----------------------------------------------------------------------- NPZ


def test_npz_round_trip_is_exact(tmp_path):
    demo = _demo(label="reach", user="3", index=np.int64(4), t0=1.5, tags=["a", "b"], nested={"k": 1})
    path = write_npz(demo, tmp_path / "d.data")  # no ".npz" appended
    assert path == tmp_path / "d.data" and path.exists()
    back = read_npz(path)
    np.testing.assert_array_equal(back.t, demo.t)
    assert back.stream_names == demo.stream_names
    for name in demo.stream_names:
        np.testing.assert_array_equal(back[name], demo[name])
    assert back.metadata == {
        "label": "reach", "user": "3", "index": 4, "t0": 1.5, "tags": ["a", "b"], "nested": {"k": 1},
    }


def test_npz_without_metadata_key(tmp_path):
    path = tmp_path / "plain.npz"
    np.savez(path, t=np.arange(3.0), position=np.ones((3, 2)))
    demo = read_npz(path)
    assert demo.metadata == {"source": str(path), "format": "npz"}
    assert demo["position"].shape == (3, 2)


def test_npz_never_unpickles(tmp_path, raises_format_error):
    path = tmp_path / "pickled.npz"
    objects = np.array([{"evil": 1}, None], dtype=object)
    np.savez(path, t=np.arange(2.0), position=objects, allow_pickle=True)
    with raises_format_error(path, r"array 'position' holds Python objects.*allow_pickle=False"):
        read_npz(path)


@pytest.mark.parametrize(
    ("arrays", "reason"),
    [
        ({"position": np.ones((3, 1))}, r"expected an array 't', found arrays \['position'\]"),
        ({"t": np.arange(3.0), "metadata": np.array("{bad json")}, "expected 'metadata' to hold valid JSON"),
        ({"t": np.arange(3.0), "metadata": np.array("[1, 2]")}, "expected 'metadata' to be a JSON object"),
        ({"t": np.arange(3.0), "metadata": np.arange(2)}, "expected 'metadata' as a 0-d JSON string"),
        ({"t": np.arange(3.0), "position": np.ones((2, 2))}, "expected 3 samples to match t"),
        ({"t": np.arange(3.0), "position": np.array(["a", "b", "c"])}, "array of real numbers"),
    ],
)
def test_npz_malformed_content(tmp_path, raises_format_error, arrays, reason):
    path = tmp_path / "bad.npz"
    np.savez(path, **arrays)
    with raises_format_error(path, reason):
        read_npz(path)


@pytest.mark.parametrize(
    ("content", "found"),
    [
        (b"t,x\n0,1\n", "found a text file$"),
        (bytes(range(256)) * 4, "found binary data"),
        (b"", "found an empty file"),
        (b"PK\x03\x04" + b"\x00" * 100, "corrupt NPZ archive"),
    ],
)
def test_npz_not_an_archive(tmp_path, raises_format_error, content, found):
    path = tmp_path / "fake.npz"
    path.write_bytes(content)
    with raises_format_error(path, found):
        read_npz(path)


def test_npz_writer_rejects_bad_input(tmp_path):
    with pytest.raises(ValueError, match="reserved"):
        write_npz(Demonstration([0.0, 1.0], {"metadata": [1.0, 2.0]}), tmp_path / "x.npz")
    with pytest.raises(ValueError, match="JSON-serialisable"):
        write_npz(_demo(fn=print), tmp_path / "x.npz")
    with pytest.raises(TypeError, match="expected a Demonstration"):
        write_npz({"t": [0.0]}, tmp_path / "x.npz")


# ---------------------------------------------------------------- properties

# Any value a Demonstration accepts: finite, of magnitude at most MAX_MAGNITUDE (issue 12).
_finite = st.floats(-MAX_MAGNITUDE, MAX_MAGNITUDE, allow_nan=False, allow_infinity=False, width=64)


@st.composite
def demonstrations(draw):
    n = draw(st.integers(1, 15))
    d = draw(st.integers(1, 4))
    start = draw(st.floats(-1e6, 1e6))
    steps = draw(hnp.arrays(np.float64, n, elements=st.floats(1e-3, 1e3)))
    values = draw(hnp.arrays(np.float64, (n, d), elements=_finite))
    return Demonstration(start + np.cumsum(steps), {"position": values}, {"n": n})


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(demo=demonstrations())
def test_csv_round_trip_property(tmp_path, demo):
    back = read_csv(write_csv(demo, tmp_path / "p.csv"))
    np.testing.assert_array_equal(back.t, demo.t)
    np.testing.assert_array_equal(back["position"], demo["position"])


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(demo=demonstrations())
def test_npz_round_trip_property(tmp_path, demo):
    back = read_npz(write_npz(demo, tmp_path / "p.npz"))
    np.testing.assert_array_equal(back.t, demo.t)
    np.testing.assert_array_equal(back["position"], demo["position"])
    assert back.metadata == demo.metadata


# ---------------------------------------------------------------------- JSON


def test_to_jsonable_converts_numpy_and_friends():
    demo = Demonstration.from_array([[1.0], [2.0]], metadata={"k": np.float32(0.5)})
    value = to_jsonable({
        "i": np.int32(3), "f": np.float64(0.25), "b": np.bool_(True), "a": np.arange(3),
        "nested": [(np.int64(1), {2: np.array([[0.5]])})], "path": Path("a/b"), "s": {3},
        "demo": demo,
    })
    assert value == {
        "i": 3, "f": 0.25, "b": True, "a": [0, 1, 2], "nested": [[1, {"2": [[0.5]]}]],
        "path": "a/b", "s": [3], "demo": {"t": [0.0, 1.0], "streams": {"position": [[1.0], [2.0]]},
                                          "metadata": {"k": 0.5}},
    }
    assert type(value["i"]) is int and type(value["b"]) is bool
    json.dumps(value)
    with pytest.raises(TypeError, match="cannot convert object"):
        to_jsonable(object())


def test_write_json(tmp_path):
    path = write_json({"scores": np.array([0.5, 1.0]), "n": np.int64(2)}, tmp_path / "r.json")
    text = path.read_text()
    assert text.startswith('{\n  "scores": [\n    0.5,')
    assert json.loads(text) == {"scores": [0.5, 1.0], "n": 2}
