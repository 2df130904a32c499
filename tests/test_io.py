import numpy as np
import pytest
from PIL import Image

from graspjax.io import InputError, check_depth, downsample, load_depth, write_atomic


def test_npy_in_metres_and_png_in_millimetres(tmp_path):
    depth = np.full((20, 30), 0.512, np.float32)
    depth[3, 4] = 0.0
    np.save(tmp_path / "d.npy", depth)
    Image.fromarray((depth * 1000).round().astype(np.uint16)).save(tmp_path / "d.png")
    np.testing.assert_array_equal(load_depth(tmp_path / "d.npy"), depth)
    np.testing.assert_allclose(load_depth(tmp_path / "d.png"), depth, atol=1e-6)


@pytest.mark.parametrize("make, match", [
    (lambda p: None, "no such file"),
    (lambda p: np.save(p / "x.npy", -np.ones((10, 10), np.float32)), "negative depth"),
    (lambda p: np.save(p / "x.npy", np.zeros((10, 10), np.float32)), "no valid depth"),
    (lambda p: np.save(p / "x.npy", np.ones((2, 10, 10), np.float32)), "2-D"),
    (lambda p: np.save(p / "x.npy", np.ones((4, 4), np.float32)), "too small"),
    (lambda p: np.save(p / "x.npy", np.ones((10, 10), np.int16)), "float depth"),
    (lambda p: (p / "x.npy").write_text("not numpy"), "cannot read"),
])
def test_bad_npy_files_raise_one_line_errors(tmp_path, make, match):
    make(tmp_path)
    with pytest.raises(InputError, match=match) as info:
        load_depth(tmp_path / "x.npy")
    assert "\n" not in str(info.value)


def test_bad_png_and_unknown_formats(tmp_path):
    Image.fromarray(np.zeros((10, 10), np.uint8)).save(tmp_path / "a.png")
    with pytest.raises(InputError, match="16-bit"):
        load_depth(tmp_path / "a.png")
    (tmp_path / "b.tiff").write_bytes(b"x")
    with pytest.raises(InputError, match="unknown depth format"):
        load_depth(tmp_path / "b.tiff")


def test_check_depth_accepts_nan_as_invalid():
    depth = np.full((10, 10), np.nan, np.float32)
    depth[5, 5] = 1.0
    assert check_depth(depth).shape == (10, 10)


def test_downsample_takes_the_median_of_valid_pixels():
    depth = np.zeros((4, 6), np.float32)
    depth[:2, :2] = [[1.0, 2.0], [3.0, 0.0]]  # median of the valid 1, 2, 3
    out = downsample(depth, 2)
    assert out.shape == (2, 3)
    assert out[0, 0] == 2.0 and out[1, 2] == 0.0


def test_write_atomic_leaves_nothing_on_failure(tmp_path):
    write_atomic(tmp_path / "a.txt", b"hello")
    assert (tmp_path / "a.txt").read_bytes() == b"hello"
    with pytest.raises(FileNotFoundError):
        write_atomic(tmp_path / "missing" / "a.txt", b"x")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]
