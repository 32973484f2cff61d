"""The comparison report: strict JSON and an escaped, self-contained HTML page."""
import json
import math
import re

import pytest

from native.evaluation.report import CYCLES_COLOUR, LUXEL_COLOUR, speed_error_svg, write_report
from test_plot import parse, polyline_points, texts

AWKWARD_NAME = '<b>&"'


def synthetic_report():
    return {
        "title": "Cornell box", "scene": "cornell.blend", "created": "2025-01-02T03:04:05",
        "luxel_version": "1.0.0", "blender_version": "4.2.0",
        "device": {"luxel": "NVIDIA H100/PCIe/SSE2", "cycles": "CUDA"},
        "settings": {"luxel": {"shots": 2000, "projection": "hemisphere"},
                     "cycles_samples": 1024, "view_samples": 256, "resolution": [640, 480],
                     "fov_degrees": 60.0, "yee_pixel_threshold": 0.012,
                     "error_map_scale": 0.25},
        "rms": 0.031, "rel_rms": 0.0125, "max_error": math.nan, "texels": 12345,
        "flip_mean": 0.05, "yee_fraction": 0.5, "cycles_samples": 1024,
        "luxel": {"seconds": 1.5, "shots": 2000, "texels": 12345, "unshot": 0.8},
        "objects": [
            {"name": AWKWARD_NAME, "texels": 100, "rms": 0.02, "rel_rms": 0.01,
             "max_error": math.inf, "luxel_mean": [0.1, 0.2, math.nan],
             "cycles_mean": [0.1, 0.2, 0.3], "error_map": "error_maps/awkward.png"},
            {"name": "Floor", "texels": 200, "rms": 0.03, "rel_rms": 0.02, "max_error": 0.1,
             "luxel_mean": [0.5, 0.5, 0.5], "cycles_mean": [0.5, 0.5, 0.5],
             "error_map": "error_maps/floor.png"},
        ],
        "views": [
            {"name": "Camera", "source": "camera", "cycles_image": "views/camera_cycles.png",
             "luxel_image": "views/camera_luxel.png", "yee_map": "views/camera_yee.png",
             "flip_map": "views/camera_flip.png", "yee_failed_pixels": 321,
             "yee_fraction": 0.004, "yee_different": False, "flip_mean": 0.04},
            {"name": "View 1", "source": "automatic", "cycles_image": "views/v1_cycles.png",
             "luxel_image": "views/v1_luxel.png", "yee_map": "views/v1_yee.png",
             "flip_map": "views/v1_flip.png", "yee_failed_pixels": 9000,
             "yee_fraction": 0.03, "yee_different": True, "flip_mean": math.nan},
        ],
        "curves": {"luxel": [{"shots": 10, "seconds": 0.1, "rms": 0.2, "rel_rms": 0.1},
                             {"shots": 100, "seconds": 1.0, "rms": 0.05, "rel_rms": 0.02}],
                   "cycles": [{"samples": 16, "seconds": 4.0, "rms": 0.3, "rel_rms": 0.15},
                              {"samples": 256, "seconds": 60.0, "rms": 0.06,
                               "rel_rms": math.nan}]},
        "curve_plot": "speed_error.svg",
    }


def refuse_constant(name):
    raise AssertionError(f"non-standard JSON constant {name}")


def test_the_json_is_strict_with_non_finite_numbers_as_null(tmp_path):
    json_path, html_path = write_report(tmp_path, synthetic_report())
    assert (json_path, html_path) == (tmp_path / "report.json", tmp_path / "report.html")
    parsed = json.loads(json_path.read_text(), parse_constant=refuse_constant)
    assert parsed["max_error"] is None and parsed["rms"] == 0.031
    assert parsed["objects"][0]["max_error"] is None
    assert parsed["objects"][0]["luxel_mean"] == [0.1, 0.2, None]
    assert parsed["views"][1]["flip_mean"] is None
    assert parsed["curves"]["cycles"][1]["rel_rms"] is None
    assert parsed["settings"]["resolution"] == [640, 480]
    assert parsed["objects"][0]["name"] == AWKWARD_NAME
    # Written in place through a temporary name: nothing else is left behind.
    assert sorted(path.name for path in tmp_path.iterdir()) == ["report.html", "report.json"]


def test_the_html_shows_every_image_and_object_and_escapes_names(tmp_path):
    report = synthetic_report()
    page = write_report(tmp_path, report)[1].read_text()
    for view in report["views"]:
        for key in ("cycles_image", "luxel_image", "yee_map", "flip_map"):
            assert f'src="{view[key]}"' in page
    for item in report["objects"]:
        assert f'src="{item["error_map"]}"' in page
    assert 'href="speed_error.svg"' in page
    assert "&lt;b&gt;&amp;&quot;" in page and AWKWARD_NAME not in page
    assert "Floor" in page and "View 1" in page
    assert "1.25 %" in page             # the relative RMS as a percentage
    assert "image-rendering: pixelated" in page
    # Nothing is fetched: the only address is the inline SVG's namespace name.
    assert "<script" not in page
    assert "http" not in page.replace('xmlns="http://www.w3.org/2000/svg"', "")


def test_missing_optional_keys_still_write_a_page(tmp_path):
    report = synthetic_report()
    for key in ("views", "objects", "curves", "curve_plot", "device", "luxel"):
        del report[key]
    json_path, html_path = write_report(tmp_path / "new folder", report)
    page = html_path.read_text()
    assert "Cornell box" in page and "<img" not in page and "<svg" not in page
    assert json.loads(json_path.read_text())["title"] == "Cornell box"
    write_report(tmp_path, {})
    write_report(tmp_path, {"views": None, "settings": None, "curves": None, "objects": None})
    assert (tmp_path / "report.html").read_text().startswith("<!DOCTYPE html>")


def inline_svgs(page):
    return [parse(svg) for svg in re.findall(r"<svg\b.*?</svg>", page, flags=re.DOTALL)]


def test_the_html_draws_the_speed_error_plot_inline(tmp_path):
    page = write_report(tmp_path, synthetic_report())[1].read_text()
    [plot] = inline_svgs(page)
    assert {"Luxel", "Cycles", "seconds", "relative RMS against the reference",
            "Speed against error"} <= set(texts(plot))
    assert len(polyline_points(plot, LUXEL_COLOUR)) == 2
    # Cycles' second point has no error: only its first is drawn.
    assert len(polyline_points(plot, CYCLES_COLOUR)) == 1


def test_the_speed_error_plot_puts_the_faster_curve_left():
    plot = parse(speed_error_svg(synthetic_report()["curves"]))
    luxel, cycles = polyline_points(plot, LUXEL_COLOUR), polyline_points(plot, CYCLES_COLOUR)
    assert luxel[:, 0].max() < cycles[:, 0].min()
    with pytest.raises(ValueError):
        speed_error_svg({"luxel": [], "cycles": []})


def test_curves_without_a_point_to_plot_still_write_a_page(tmp_path):
    report = synthetic_report()
    report["curves"] = {"luxel": [{"shots": 1, "seconds": 0.1, "rel_rms": math.nan}]}
    page = write_report(tmp_path, report)[1].read_text()
    assert "<svg" not in page and "No curve has a positive time and error" in page
    assert "Luxel convergence" in page
