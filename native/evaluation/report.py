"""The Luxel-against-Cycles comparison report: report.json (strict JSON: NaN and infinities
become null) and report.html, one static page with inline CSS and the speed-against-error
plot as inline SVG, beside the images the caller wrote. Every string from the report is
HTML-escaped; optional keys may be missing."""
import html
import json
import math
from pathlib import Path
from urllib.parse import quote

from ..output import _atomic_write
from .plot import Series, log_log_plot

LUXEL_COLOUR, CYCLES_COLOUR = "#d62728", "#1f77b4"

_STYLE = """
body { font-family: sans-serif; margin: 2em auto; max-width: 1400px; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; }
th, td { border: 1px solid #ccc; padding: 0.3em 0.6em; text-align: left; vertical-align: top; }
th { background: #f2f2f2; }
td.number { text-align: right; font-variant-numeric: tabular-nums; }
svg.plot { max-width: 100%; height: auto; }
img.view { width: 240px; display: block; }
img.error-map { width: 256px; image-rendering: pixelated; display: block; }
.scale { display: inline-block; width: 256px; height: 1em; vertical-align: middle;
         background: linear-gradient(to right, #000, #00f, #0f0, #ff0, #fff); }
.meta { color: #666; }
"""


def speed_error_svg(curves):
    """Log-log SVG of relative RMS against seconds for the "luxel" and "cycles" curves.
    Raises ValueError (from log_log_plot) if neither has a positive point."""
    def series(label, points, colour):
        points = points or []
        def values(key):
            return [math.nan if point.get(key) is None else point[key] for point in points]
        return Series(label, values("seconds"), values("rel_rms"), colour)
    return log_log_plot([series("Luxel", curves.get("luxel"), LUXEL_COLOUR),
                         series("Cycles", curves.get("cycles"), CYCLES_COLOUR)],
                        x_label="seconds", y_label="relative RMS against the reference",
                        title="Speed against error")


def write_report(directory, report):
    """Write report.json and report.html into ``directory``; returns their two paths."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    json_path, html_path = directory / "report.json", directory / "report.html"
    text = json.dumps(_strict(report), indent=2, allow_nan=False)
    _atomic_write(json_path, lambda name: Path(name).write_text(text, encoding="utf-8"))
    page = _html(report)
    _atomic_write(html_path, lambda name: Path(name).write_text(page, encoding="utf-8"))
    return json_path, html_path


def _strict(value):
    """A copy with non-finite floats as None, so the JSON parses anywhere."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {key: _strict(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_strict(item) for item in value]
    return value


def _format(value, percent=False, unit=""):
    """Escaped display text: 4 significant digits, 'n/a' for missing or non-finite."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (list, tuple)):
        return ", ".join(_format(item) for item in value)
    if isinstance(value, (int, float)):
        if not math.isfinite(value):
            return "n/a"
        if percent:
            return f"{value * 100:.4g} %"
        text = f"{value:,}" if isinstance(value, int) else f"{value:.4g}"
        return text + (f" {unit}" if unit else "")
    return "n/a" if value is None else html.escape(str(value))


def _table(header, rows):
    """``rows`` hold ready HTML; cells of numbers are right-aligned."""
    head = "".join(f"<th>{html.escape(title)}</th>" for title in header)
    body = "".join(
        "<tr>" + "".join(f'<td class="number">{cell[1]}</td>' if isinstance(cell, tuple)
                         else f"<td>{cell}</td>" for cell in row) + "</tr>\n"
        for row in rows)
    return f"<table>\n<tr>{head}</tr>\n{body}</table>\n"


def _number(value, **options):
    """A right-aligned cell for _table."""
    return ("number", _format(value, **options))


def _address(path):
    return html.escape(quote(str(path), safe="/"))


def _image(path, alt, css_class):
    if not path:
        return '<span class="meta">none</span>'
    return (f'<a href="{_address(path)}"><img class="{css_class}" src="{_address(path)}" '
            f'alt="{html.escape(alt)}"></a>')


def _link(path):
    return f'<a href="{_address(path)}">{html.escape(str(path))}</a>'


def _speed_error_figure(curves):
    try:
        return f"<p>{speed_error_svg(curves)}</p>\n"
    except ValueError:
        # A run whose errors are all missing still deserves its page.
        return '<p class="meta">No curve has a positive time and error to plot.</p>\n'


def _html(report):
    # A key may be missing or null: treat both as empty.
    settings, luxel = report.get("settings") or {}, report.get("luxel") or {}
    device, views = report.get("device") or {}, report.get("views") or []
    title = html.escape(str(report.get("title", "Luxel against Cycles")))
    meta = " &middot; ".join(
        f"{label} {html.escape(str(report[key]))}" for label, key in
        [("scene", "scene"), ("created", "created"), ("Luxel", "luxel_version"),
         ("Blender", "blender_version")] if key in report)
    different = sum(bool(view.get("yee_different")) for view in views)
    views_note = f" ({different} of {len(views)})" if views else ""
    summary = [
        ("Relative RMS", _number(report.get("rel_rms"), percent=True)),
        ("RMS", _number(report.get("rms"))),
        ("Max error", _number(report.get("max_error"))),
        ("Texels compared", _number(report.get("texels"))),
        ("Reference's own noise (relative RMS; the floor of any error against it)",
         _number(report.get("reference_noise_rel"), percent=True)),
        ("FLIP mean", _number(report.get("flip_mean"))),
        ("Views Yee judges different",
         ("number", _format(report.get("yee_fraction"), percent=True) + views_note)),
        ("Cycles samples", _number(report.get("cycles_samples"))),
        ("Cycles reference time", _number(report.get("cycles_seconds"), unit="s")),
        ("Luxel time", _number(luxel.get("seconds"), unit="s")),
        ("Luxel shots", _number(luxel.get("shots"))),
        ("Luxel texels", _number(luxel.get("texels"))),
        ("Luxel unshot energy", _number(luxel.get("unshot"), unit="%")),
        ("Luxel device", _format(device.get("luxel"))),
        ("Cycles device", _format(device.get("cycles"))),
    ]
    parts = [f"<h1>{title}</h1>\n<p class=\"meta\">{meta}</p>\n",
             "<h2>Summary</h2>\n", _table(["Measure", "Value"], summary)]

    curves = report.get("curves") or {}
    if curves:
        parts += ["<h2>Speed against error</h2>\n", _speed_error_figure(curves)]
        if report.get("curve_plot"):
            parts.append(f'<p class="meta">As a file: {_link(report["curve_plot"])}</p>\n')

    if views:
        rows = []
        for view in views:
            about = (f"<b>{_format(view.get('name'))}</b><br>{_format(view.get('source'))}"
                     f"<br>Yee failed pixels: {_format(view.get('yee_failed_pixels'))}"
                     f" ({_format(view.get('yee_fraction'), percent=True)})"
                     f"<br>Yee judges different: {_format(view.get('yee_different'))}"
                     f"<br>FLIP mean: {_format(view.get('flip_mean'))}")
            name = str(view.get("name", "view"))
            rows.append([about] + [_image(view.get(key), f"{name}: {label}", "view")
                                   for key, label in [("cycles_image", "Cycles"),
                                                      ("luxel_image", "Luxel"),
                                                      ("yee_map", "Yee failed pixels"),
                                                      ("flip_map", "FLIP map")]])
        parts += ["<h2>Views</h2>\n",
                  _table(["View", "Cycles", "Luxel", "Yee failed pixels", "FLIP map"], rows)]

    scale = settings.get("error_map_scale")
    parts += ["<h2>Objects</h2>\n",
              f'<p>Error maps show the length of the RGB difference per texel: '
              f'<span class="scale"></span> black at 0 through blue, green and yellow to '
              f'white at {_format(scale)} and above; grey outside the surfaces.</p>\n']
    if report.get("objects"):
        parts.append(_table(
            ["Object", "Texels", "RMS", "Relative RMS", "Max error", "Reference noise",
             "Luxel mean RGB", "Cycles mean RGB", "Error map"],
            [[_format(item.get("name")), _number(item.get("texels")), _number(item.get("rms")),
              _number(item.get("rel_rms"), percent=True), _number(item.get("max_error")),
              _number(item.get("reference_noise_rms")),
              _number(item.get("luxel_mean")), _number(item.get("cycles_mean")),
              _image(item.get("error_map"), f"{item.get('name', '')} error map", "error-map")]
             for item in report["objects"]]))

    for key, label, count in [("luxel", "Luxel", "shots"), ("cycles", "Cycles", "samples")]:
        if curves.get(key):
            parts += [f"<h2>{label} convergence</h2>\n", _table(
                [count.capitalize(), "Seconds", "RMS", "Relative RMS"],
                [[_number(point.get(count)), _number(point.get("seconds")),
                  _number(point.get("rms")), _number(point.get("rel_rms"), percent=True)]
                 for point in curves[key]])]

    parts.append("<h2>Settings</h2>\n")
    luxel_settings = settings.get("luxel") or {}
    if luxel_settings:
        parts.append(_table(["Luxel setting", "Value"],
                            [[_format(key), _format(value)]
                             for key, value in luxel_settings.items()]))
    parts.append(_table(["Comparison setting", "Value"],
                        [[_format(str(key).replace("_", " ")), _format(value)]
                         for key, value in settings.items() if key != "luxel"]))
    return (f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
            f"<title>{title}</title>\n<style>{_STYLE}</style>\n</head>\n<body>\n"
            + "".join(parts) + "</body>\n</html>\n")
