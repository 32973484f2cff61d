"""The SVG log-log plot, parsed as XML and checked against positions computed here."""
import math
import xml.etree.ElementTree as ElementTree

import numpy as np
import pytest

from native.evaluation.plot import Series, log_log_plot

RED, BLUE, GREEN = "#c81414", "#1428d2", "#0aa01e"
SVG = "{http://www.w3.org/2000/svg}"


def parse(svg):
    root = ElementTree.fromstring(svg)
    assert root.tag == f"{SVG}svg"
    return root


def frame_of(root):
    """(left, top, right, bottom) of the plot box, the rectangle the SVG marks as its frame."""
    rect = root.find(f"{SVG}rect[@class='frame']")
    left, top = float(rect.get("x")), float(rect.get("y"))
    return left, top, left + float(rect.get("width")), top + float(rect.get("height"))


def polyline_points(root, colour):
    lines = [line for line in root.iter(f"{SVG}polyline") if line.get("stroke") == colour]
    assert len(lines) <= 1
    if not lines:
        return np.empty((0, 2))
    return np.array([[float(v) for v in pair.split(",")]
                     for pair in lines[0].get("points").split()])


def texts(root):
    return {element.text: element for element in root.iter(f"{SVG}text")}


def log_position(value, low, high, first, last):
    """Where ``value`` lands on an axis from ``low`` at ``first`` to ``high`` at ``last``."""
    fraction = (math.log10(value) - math.log10(low)) / (math.log10(high) - math.log10(low))
    return first + fraction * (last - first)


def test_the_svg_is_well_formed_with_the_requested_size():
    svg = log_log_plot([Series("a", [1, 2, 3], [3, 1, 2], RED)], x_label="x", y_label="y",
                       width=400, height=300)
    root = parse(svg)
    assert (root.get("width"), root.get("height"), root.get("viewBox")) == (
        "400", "300", "0 0 400 300")


def test_points_and_ticks_map_to_the_frame_through_log_axes_of_whole_decades():
    xs, ys = [3.0, 20.0, 400.0], [0.05, 0.005, 0.002]
    root = parse(log_log_plot([Series("a", xs, ys, RED)], x_label="x", y_label="y"))
    left, top, right, bottom = frame_of(root)
    # The data spans 3..400 and 0.002..0.05: the axes round out to 1..1000 and 0.001..0.1.
    expected = [(log_position(x, 1, 1000, left, right), log_position(y, 0.001, 0.1, bottom, top))
                for x, y in zip(xs, ys)]
    assert polyline_points(root, RED) == pytest.approx(np.array(expected), abs=0.01)
    labels = texts(root)
    for value, label in [(1, "1"), (10, "10"), (100, "100"), (1000, "1000")]:
        assert float(labels[label].get("x")) == pytest.approx(
            log_position(value, 1, 1000, left, right), abs=0.01)
        assert float(labels[label].get("y")) > bottom
    for value, label in [(0.001, "0.001"), (0.01, "0.01"), (0.1, "0.1")]:
        assert float(labels[label].get("x")) < left
        # The baseline sits a little below the tick, so the digits centre on it.
        row = log_position(value, 0.001, 0.1, bottom, top)
        assert row < float(labels[label].get("y")) < row + 10


def test_data_in_one_decade_gets_a_decade_each_side():
    """A single point at (1, 1) shares a decade with itself: axes 0.1..10, the frame's centre."""
    root = parse(log_log_plot([Series("one", [1.0], [1.0], RED)], x_label="x", y_label="y"))
    left, top, right, bottom = frame_of(root)
    assert polyline_points(root, RED) == pytest.approx(
        np.array([[(left + right) / 2, (top + bottom) / 2]]), abs=0.01)
    assert {"0.1", "1", "10"} <= set(texts(root))


def test_wide_ranges_label_at_most_nine_decades_in_exponent_form():
    root = parse(log_log_plot([Series("wide", [1e-12, 1e6], [0.2, 0.3], RED)],
                              x_label="x", y_label="y"))
    labels = set(texts(root))
    # 18 decades: every third one labelled.
    assert {"1e-12", "1e-9", "0.001", "1", "1000", "1e6"} <= labels
    assert not {"1e-11", "1e-10", "0.01", "10"} & labels


def test_title_axis_labels_and_legend_are_text():
    root = parse(log_log_plot([Series("Luxel", [1, 10], [1, 0.1], RED),
                               Series("Cycles", [5, 50], [1, 0.2], BLUE)],
                              x_label="seconds", y_label="relative RMS", title="Speed"))
    assert {"Luxel", "Cycles", "seconds", "relative RMS", "Speed"} <= set(texts(root))


def test_labels_are_escaped():
    label = 'a < b & "c"'
    svg = log_log_plot([Series(label, [1, 10], [1, 2], RED)], x_label="x <", y_label="&")
    assert "a &lt; b &amp; &quot;c&quot;" in svg and label not in svg
    assert {label, "x <", "&"} <= set(texts(parse(svg)))


def test_non_positive_and_non_finite_points_are_skipped():
    root = parse(log_log_plot([Series("a", [-1, 0, 2, 5, math.nan], [1, 2, 3, 40, 1], RED)],
                              x_label="x", y_label="y"))
    left, top, right, bottom = frame_of(root)
    expected = [(log_position(x, 1, 10, left, right), log_position(y, 1, 100, bottom, top))
                for x, y in [(2, 3), (5, 40)]]
    assert polyline_points(root, RED) == pytest.approx(np.array(expected), abs=0.01)


def test_a_series_without_drawable_points_is_in_the_legend_only():
    root = parse(log_log_plot([Series("data", [1, 10, 100], [1, 5, 2], RED),
                               Series("nothing", [math.nan, -1], [1, 2], GREEN)],
                              x_label="x", y_label="y"))
    assert len(polyline_points(root, GREEN)) == 0 and len(polyline_points(root, RED)) == 3
    assert "nothing" in texts(root)
    legend = root.find(f"{SVG}rect[@class='legend']")
    left, top = float(legend.get("x")), float(legend.get("y"))
    right, bottom = left + float(legend.get("width")), top + float(legend.get("height"))
    green = [element for element in root.iter()
             if GREEN in (element.get("stroke"), element.get("fill"))]
    assert green
    for element in green:
        x = float(element.get("x", element.get("x1")))
        y = float(element.get("y", element.get("y1")))
        assert left <= x <= right and top <= y <= bottom


def test_the_legend_keeps_off_the_lines():
    """A line from corner to corner of the frame: the legend takes a corner it misses."""
    root = parse(log_log_plot([Series("diagonal", [1, 100], [1, 100], RED)],
                              x_label="x", y_label="y"))
    legend = root.find(f"{SVG}rect[@class='legend']")
    left, top = float(legend.get("x")), float(legend.get("y"))
    right, bottom = left + float(legend.get("width")), top + float(legend.get("height"))
    (x0, y0), (x1, y1) = polyline_points(root, RED)
    t = np.linspace(0, 1, 1000)
    along_x, along_y = x0 + t * (x1 - x0), y0 + t * (y1 - y0)
    assert not ((along_x >= left) & (along_x <= right)
                & (along_y >= top) & (along_y <= bottom)).any()


@pytest.mark.parametrize("series", [
    [],
    [Series("nan", [math.nan], [1.0], RED)],
    [Series("non-positive", [0.0, -1.0], [1.0, 2.0], RED), Series("empty", [], [], BLUE)],
])
def test_nothing_drawable_is_refused(series):
    with pytest.raises(ValueError, match="no series has a finite point to plot"):
        log_log_plot(series, x_label="x", y_label="y")
