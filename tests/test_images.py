"""sensor_msgs/Image <-> numpy (subsumption.images): round trips, encodings, and clear errors."""
import numpy as np
import pytest
from sensor_msgs.msg import Image

from subsumption.images import (ImageEncodingError, compressed_jpeg, from_array, from_compressed, to_array,
                                to_depth_m, to_rgb)


def test_rgb_round_trip_keeps_pixels_and_shape():
    rgb = np.random.default_rng(1).integers(0, 256, (4, 5, 3), dtype=np.uint8)
    msg = from_array(rgb, "rgb8")
    assert (msg.width, msg.height, msg.step) == (5, 4, 15)
    assert np.array_equal(to_array(msg), rgb)
    assert np.array_equal(to_rgb(msg), rgb)


def test_bgr_is_read_back_as_rgb():
    rgb = np.zeros((2, 2, 3), np.uint8)
    rgb[..., 0] = 200  # red
    msg = from_array(np.ascontiguousarray(rgb[:, :, ::-1]), "bgr8")
    assert to_rgb(msg)[0, 0].tolist() == [200, 0, 0]


def test_depth_encodings_give_metres_with_nan_for_no_reading():
    metres = np.array([[1.5, np.nan]], np.float32)
    assert np.allclose(to_depth_m(from_array(metres, "32FC1")), metres, equal_nan=True)
    millimetres = np.array([[1500, 0]], np.uint16)
    depth = to_depth_m(from_array(millimetres, "16UC1"))
    assert depth[0, 0] == pytest.approx(1.5) and np.isnan(depth[0, 1])


def test_padded_rows_are_read_by_step():
    msg = Image(height=2, width=2, encoding="mono8", step=4, data=bytes([1, 2, 99, 99, 3, 4, 99, 99]))
    assert to_array(msg).tolist() == [[1, 2], [3, 4]]


def test_bad_input_names_what_is_wrong():
    with pytest.raises(ImageEncodingError, match="unsupported image encoding 'yuv422'"):
        to_array(Image(height=1, width=1, encoding="yuv422", step=2, data=b"\0\0"))
    with pytest.raises(ImageEncodingError, match="cannot hold it"):
        to_array(Image(height=2, width=2, encoding="rgb8", step=6, data=b"\0" * 6))
    with pytest.raises(ImageEncodingError, match="is not a rgb8 image"):
        from_array(np.zeros((2, 2), np.uint8), "rgb8")
    with pytest.raises(ImageEncodingError, match="not a depth image"):
        to_depth_m(from_array(np.zeros((2, 2, 3), np.uint8), "rgb8"))


def test_jpeg_round_trip_is_close():
    rgb = np.zeros((32, 32, 3), np.uint8)
    rgb[:, :16] = (255, 0, 0)
    back = from_compressed(compressed_jpeg(rgb, quality=95))
    assert back.shape == rgb.shape
    assert np.abs(back.astype(int) - rgb).mean() < 8
