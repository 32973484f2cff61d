"""The numpy line-plot rasteriser, checked by decoding the PNG it writes."""
import math
import struct
import zlib

import numpy as np
import pytest

from native.plot import Axis, Series, draw_text, line_plot

RED, BLUE, GREEN = (200, 20, 20), (20, 40, 210), (10, 160, 30)


def read_png(path):
    """(H, W, 3) uint8 from an 8-bit RGB PNG whose rows all use filter type 0."""
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    position, compressed, header = 8, b"", None
    while position < len(data):
        length, kind = struct.unpack(">I4s", data[position:position + 8])
        body = data[position + 8:position + 8 + length]
        assert zlib.crc32(kind + body) & 0xFFFFFFFF == struct.unpack(
            ">I", data[position + 8 + length:position + 12 + length])[0]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            compressed += body
        position += 12 + length
    width, height, depth, colour_type = header[:4]
    assert (depth, colour_type) == (8, 2)
    rows = np.frombuffer(zlib.decompress(compressed), np.uint8).reshape(height, 1 + 3 * width)
    assert (rows[:, 0] == 0).all()
    return rows[:, 1:].reshape(height, width, 3)


def pixels_of(image, colour):
    return np.argwhere((image == np.array(colour, np.uint8)).all(axis=2))  # (row, column)


def test_axis_maps_log_and_linear_values_proportionally():
    assert Axis(1.0, 100.0, True, 0, 100).to_pixel(10.0) == pytest.approx(50.0)
    assert Axis(0.0, 10.0, False, 100, 200).to_pixel(2.5) == pytest.approx(125.0)
    # A vertical axis runs from its bottom row up: larger values land on smaller rows.
    assert Axis(1.0, 1000.0, True, 400, 100).to_pixel(10.0) == pytest.approx(300.0)


def test_the_png_has_the_requested_size_and_a_white_background(tmp_path):
    path = tmp_path / "plot.png"
    line_plot(path, [Series("a", [1, 2, 3], [3, 1, 2], RED)], "x", "y", size=(400, 300))
    image = read_png(path)
    assert image.shape == (300, 400, 3)
    assert (image[0, 0] == 255).all() and (image[-1, -1] == 255).all()
    assert len(pixels_of(image, RED)) > 100


def test_a_rising_series_lies_up_and_right_of_a_falling_one(tmp_path):
    path = tmp_path / "plot.png"
    line_plot(path, [Series("rising", [10, 100], [10, 100], RED),
                     Series("falling", [1, 10], [10, 1], BLUE)], "x", "y")
    image = read_png(path)
    rising, falling = pixels_of(image, RED).mean(axis=0), pixels_of(image, BLUE).mean(axis=0)
    assert rising[1] > falling[1] + 100     # further right
    assert rising[0] < falling[0] - 50      # higher up: a smaller row


def test_a_marker_lands_at_the_log_proportional_position_inside_the_frame(tmp_path):
    """Axes from 1 to 100 (the data's whole decades): x = y = 10 is the frame's centre."""
    path = tmp_path / "plot.png"
    x_axis, y_axis = line_plot(path, [Series("frame", [1, 2, 100], [100, 1, 3], RED),
                                      Series("centre", [10], [10], BLUE)], "x", "y")
    assert (x_axis.low, x_axis.high, y_axis.low, y_axis.high) == (1, 100, 1, 100)
    image = read_png(path)
    # The frame is the dark outline: the rows and columns holding the most dark pixels.
    dark = (image < 80).all(axis=2)
    rows = np.flatnonzero(dark.sum(axis=1) > dark.sum(axis=1).max() // 2)
    columns = np.flatnonzero(dark.sum(axis=0) > dark.sum(axis=0).max() // 2)
    top, bottom, left, right = rows[0], rows[-1], columns[0], columns[-1]
    assert (left, right, bottom, top) == (x_axis.first_pixel, x_axis.last_pixel,
                                          y_axis.first_pixel, y_axis.last_pixel)
    column, row = round((left + right) / 2), round((top + bottom) / 2)
    assert x_axis.to_pixel(10) == pytest.approx((left + right) / 2)
    marker = image[row - 2:row + 3, column - 2:column + 3]
    assert (marker == np.array(BLUE, np.uint8)).all()


def test_axes_round_out_to_decades_or_nice_steps(tmp_path):
    x_axis, y_axis = line_plot(tmp_path / "plot.png",
                               [Series("a", [0.03, 0.5, 4.0], [0.13, 0.5, 0.87], RED)],
                               "x", "y", log_x=True, log_y=False)
    assert (x_axis.low, x_axis.high) == pytest.approx((0.01, 10.0))
    assert 0.0 <= y_axis.low <= 0.13 and 0.87 <= y_axis.high <= 1.0


def test_non_positive_values_are_skipped_on_log_axes(tmp_path):
    x_axis, y_axis = line_plot(tmp_path / "plot.png",
                               [Series("a", [-1, 0, 2, 5], [1, 2, 3, 40], RED)], "x", "y")
    assert (x_axis.low, x_axis.high) == pytest.approx((1.0, 10.0))
    assert (y_axis.low, y_axis.high) == pytest.approx((1.0, 100.0))


def test_a_series_without_finite_points_is_in_the_legend_only(tmp_path):
    path = tmp_path / "plot.png"
    line_plot(path, [Series("data", [1, 10, 100], [1, 5, 2], RED),
                     Series("nothing", [math.nan, math.inf], [1, 2], GREEN)], "x", "y")
    image = read_png(path)
    swatch = pixels_of(image, GREEN)
    assert 0 < len(swatch) < 200
    # The legend swatch is one short horizontal stroke with a marker, not a plotted line.
    assert np.ptp(swatch[:, 1]) <= 30 and np.ptp(swatch[:, 0]) <= 8


@pytest.mark.parametrize("series", [
    [],
    [Series("nan", [math.nan], [1.0], RED)],
    [Series("non-positive", [0.0, -1.0], [1.0, 2.0], RED), Series("empty", [], [], BLUE)],
])
def test_nothing_drawable_is_refused(tmp_path, series):
    with pytest.raises(ValueError):
        line_plot(tmp_path / "plot.png", series, "x", "y")
    assert not (tmp_path / "plot.png").exists()


def test_the_font_has_a_distinct_glyph_for_every_character_labels_need():
    def rendered(text):
        image = np.full((24, 16, 3), 255, np.uint8)
        draw_text(image, text, 1, 1)
        return (image < 128).all(axis=2)

    characters = ("0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"
                  ".,-+%()/=:_")
    unknown = rendered("\u2603")
    glyphs = [rendered(character) for character in characters]
    for character, glyph in zip(characters, glyphs):
        assert glyph.any() and not (glyph == unknown).all(), character
    distinct = {glyph.tobytes() for glyph in glyphs}
    assert len(distinct) == len(characters)
    assert not rendered(" ").any()
