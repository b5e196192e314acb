"""``--video`` writes each frame as it is rendered: memory does not grow with the video (41)."""

from __future__ import annotations

import tracemalloc
import types

import numpy as np
import pytest

from skillbank.simulation._video import Recorder, _gif_frame, _gif_header

Image = pytest.importorskip("PIL.Image")

W, H = 480, 360


class _FakeRenderer:
    """mujoco.Renderer's interface: a new frame (a moving gradient) at each render."""

    def __init__(self, M, height, width):
        self.k, self.shape = 0, (height, width, 3)

    def update_scene(self, d, camera=None):
        self.k += 1

    def render(self):
        y, x = np.mgrid[:self.shape[0], :self.shape[1]]
        frame = np.empty(self.shape, np.uint8)
        frame[..., 0] = (x + 7 * self.k) % 256
        frame[..., 1] = (y + 3 * self.k) % 256
        frame[..., 2] = (x + y) % 256
        return frame

    def close(self):
        pass


FAKE_MUJOCO = types.SimpleNamespace(Renderer=_FakeRenderer,
                                    MjvCamera=lambda: types.SimpleNamespace(lookat=np.zeros(3)))


def test_the_frames_written_one_by_one_read_back_as_an_animated_gif(tmp_path):
    frames = [np.full((20, 30, 3), v, np.uint8) for v in (0, 120, 255)]
    frames[1][5:10, 5:10] = (255, 0, 0)
    path = tmp_path / "x.gif"
    path.write_bytes(_gif_header(30, 20) + b"".join(_gif_frame(f, 4) for f in frames) + b";")
    with Image.open(path) as image:
        assert image.format == "GIF" and image.n_frames == 3 and image.size == (30, 20)
        for k, frame in enumerate(frames):
            image.seek(k)
            assert image.info["duration"] == 40 and image.info.get("loop") == 0
            assert np.array_equal(np.asarray(image.convert("RGB")), frame)


def test_memory_does_not_grow_with_the_frames(tmp_path):
    path = tmp_path / "long.gif"
    recorder = Recorder(FAKE_MUJOCO, None, path, fps=25.0, size=(W, H))
    try:
        for _ in range(5):
            recorder.add(None)
        tracemalloc.start()
        for _ in range(200):  # 200 frames of 518 KB: 104 MB were they kept
            recorder.add(None)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        assert peak < 12 * W * H * 3  # a few frames' worth, whatever the count
        assert not path.exists()  # written beside it until the end
        assert recorder.write() == path
    finally:
        recorder.close()
    with Image.open(path) as image:
        assert image.n_frames == 205 and image.size == (W, H)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["long.gif"]


def test_a_video_not_finished_leaves_nothing_and_the_old_file(tmp_path):
    path = tmp_path / "v.gif"
    path.write_bytes(b"old")
    recorder = Recorder(FAKE_MUJOCO, None, path)
    recorder.add(None)
    recorder.close()  # the simulation failed before write()
    assert path.read_bytes() == b"old" and sorted(p.name for p in tmp_path.iterdir()) == ["v.gif"]
    empty = Recorder(FAKE_MUJOCO, None, tmp_path / "none.gif")
    with pytest.raises(ValueError, match="^video: the simulation rendered no frame$"):
        empty.write()
    empty.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v.gif"]
