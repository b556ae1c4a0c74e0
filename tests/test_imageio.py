"""Map files round-trip through OpenImageIO: EXR bit-identical, PNG within its quantisation."""

import os

import numpy as np
import pytest

from porous_weathering.common import imageio


@pytest.fixture
def values():
    return np.random.default_rng(7).uniform(-0.5, 4.0, size=(13, 17)).astype(np.float32)


def test_float_exr_is_bit_identical_and_keeps_metadata(tmp_path, values):
    path = tmp_path / "map.exr"
    imageio.write_image(path, values, metadata={"pw:inputs": "abc123"})
    pixels, metadata = imageio.read_image(path)
    assert pixels.shape == (13, 17, 1)
    assert np.array_equal(pixels[..., 0], values)
    assert metadata["pw:inputs"] == "abc123" and imageio.read_metadata(path)["pw:inputs"] == "abc123"


def test_half_exr_is_bit_identical_to_float16(tmp_path, values):
    imageio.write_image(tmp_path / "map.exr", values, pixel_type="half")
    pixels, _ = imageio.read_image(tmp_path / "map.exr")
    assert np.array_equal(pixels[..., 0], values.astype(np.float16).astype(np.float32))


def test_png16_is_within_quantisation(tmp_path, values):
    colour = np.stack([values, values / 4, 1 - values / 4], axis=-1)
    imageio.write_image(tmp_path / "map.png", colour)
    pixels, _ = imageio.read_image(tmp_path / "map.png")
    expected = np.clip(colour, 0, 1)
    assert np.abs(pixels - expected).max() <= 0.5 / 65535 + 1e-7
    assert not np.array_equal(pixels, expected)  # it is quantised: the check can tell


def test_write_is_atomic_and_leaves_no_temporary_files(tmp_path, values, monkeypatch):
    path = tmp_path / "map.exr"
    imageio.write_image(path, values)
    import OpenImageIO as oiio

    monkeypatch.setattr(oiio.ImageOutput, "create", staticmethod(lambda name: None))
    with pytest.raises(OSError, match="map.exr"):
        imageio.write_image(path, values * 2)
    pixels, _ = imageio.read_image(path)
    assert np.array_equal(pixels[..., 0], values)  # the old map survives a failed write
    assert os.listdir(tmp_path) == ["map.exr"]


def test_bad_destinations_are_named(tmp_path, values):
    with pytest.raises(OSError, match="missing"):
        imageio.write_image(tmp_path / "missing" / "map.exr", values)
    with pytest.raises(ValueError, match="tif"):
        imageio.write_image(tmp_path / "map.tif", values)
    with pytest.raises(FileNotFoundError, match="nothing.exr"):
        imageio.read_image(tmp_path / "nothing.exr")
    assert imageio.read_metadata(tmp_path / "nothing.exr") == {}
