"""Log-log line plots as SVG text, for reports made inside Blender, where matplotlib is not
available: the page embeds the SVG and the browser draws its text."""
from dataclasses import dataclass
import html
import math

import numpy as np

FONT_SIZE = 13
# The browser measures the text; layout only needs a safe guess at its width.
CHARACTER_WIDTH = 0.6 * FONT_SIZE
INK, GRID, MINOR_GRID = "#282828", "#dedede", "#f0f0f0"
MARKER_SIZE = 7
LINE_WIDTH = 2.5
# A text baseline this far below a point centres the label's digits on it.
BASELINE_DROP = 0.35 * FONT_SIZE


@dataclass
class Series:
    """One polyline: its legend label, data points and a CSS colour such as "#d62728"."""
    label: str
    xs: list
    ys: list
    colour: str


@dataclass(frozen=True)
class Tick:
    value: float
    label: str


@dataclass(frozen=True)
class DecadeScale:
    """A log axis rounded out to whole decades, with its labelled decade ticks and the
    unlabelled 2..9 ticks between them."""
    low: float
    high: float
    major: list
    minor: list


@dataclass(frozen=True)
class Axis:
    """Maps data to SVG coordinates in proportion to log10 of the value: ``low`` lands on
    ``first`` and ``high`` on ``last``. For the vertical axis ``first`` is the bottom edge,
    so larger values land higher."""
    low: float
    high: float
    first: float
    last: float

    def position(self, values):
        t = np.log10(np.asarray(values, float) / self.low) / math.log10(self.high / self.low)
        return self.first + t * (self.last - self.first)


@dataclass(frozen=True)
class Box:
    left: float
    top: float
    right: float
    bottom: float

    def holds(self, xs, ys):
        """How many of the points (xs, ys) lie inside."""
        return int(np.count_nonzero((xs >= self.left) & (xs <= self.right)
                                    & (ys >= self.top) & (ys <= self.bottom)))


def decade_scale(values):
    """Axis ends at the whole decades around ``values`` (positive), one more on each side when
    they share a decade, and at most nine labelled decades."""
    first = math.floor(math.log10(float(np.min(values))))
    last = math.ceil(math.log10(float(np.max(values))))
    if first == last:
        first, last = first - 1, last + 1
    stride = math.ceil((last - first) / 8)
    major = [Tick(10.0 ** k, _decade_label(k)) for k in range(first, last + 1, stride)]
    # Unlabelled 2..9 ticks only while they do not crowd the axis.
    minor = ([m * 10.0 ** k for k in range(first, last) for m in range(2, 10)]
             if last - first <= 6 else [])
    return DecadeScale(10.0 ** first, 10.0 ** last, major, minor)


def _decade_label(exponent):
    return f"{10.0 ** exponent:.{max(0, -exponent)}f}" if -3 <= exponent <= 4 else f"1e{exponent}"


def _text_width(text):
    return len(text) * CHARACTER_WIDTH


def _number(value):
    return f"{value:.2f}"


def _text(text, x, y, anchor="start"):
    return (f'<text x="{_number(x)}" y="{_number(y)}" text-anchor="{anchor}">'
            f"{html.escape(text)}</text>")


def _line(x1, y1, x2, y2, colour, width=1):
    return (f'<line x1="{_number(x1)}" y1="{_number(y1)}" x2="{_number(x2)}" '
            f'y2="{_number(y2)}" stroke="{colour}" stroke-width="{width}"/>')


def _marker(x, y, colour):
    return (f'<rect x="{_number(x - MARKER_SIZE / 2)}" y="{_number(y - MARKER_SIZE / 2)}" '
            f'width="{MARKER_SIZE}" height="{MARKER_SIZE}" fill="{colour}"/>')


def log_log_plot(series, *, x_label, y_label, title="", width=720, height=460):
    """An SVG document (a string, also fit to embed in HTML) of ``series`` (a list of Series)
    on log-log axes. Points that are not finite and positive are skipped; a series left with
    none is listed in the legend but not drawn. Raises ValueError if no series has a point to
    draw."""
    drawable = []
    for one in series:
        xs, ys = np.asarray(one.xs, float).ravel(), np.asarray(one.ys, float).ravel()
        keep = np.isfinite(xs) & np.isfinite(ys) & (xs > 0) & (ys > 0)
        drawable.append((xs[keep], ys[keep]))
    if not any(len(xs) for xs, _ in drawable):
        raise ValueError("no series has a finite point to plot"
                         " (log axes need positive values)")
    x_scale = decade_scale(np.concatenate([xs for xs, _ in drawable]))
    y_scale = decade_scale(np.concatenate([ys for _, ys in drawable]))

    frame = Box(left=max(_text_width(tick.label) for tick in y_scale.major) + 16,
                top=2 * FONT_SIZE + 30, right=width - 32, bottom=height - 2 * FONT_SIZE - 28)
    x_axis = Axis(x_scale.low, x_scale.high, frame.left, frame.right)
    y_axis = Axis(y_scale.low, y_scale.high, frame.bottom, frame.top)

    grid = [_line(x, frame.top, x, frame.bottom, MINOR_GRID)
            for x in x_axis.position(x_scale.minor)]
    grid += [_line(frame.left, y, frame.right, y, MINOR_GRID)
             for y in y_axis.position(y_scale.minor)]
    ticks = []
    for tick in x_scale.major:
        x = x_axis.position(tick.value)
        grid.append(_line(x, frame.top, x, frame.bottom, GRID))
        ticks += [_line(x, frame.bottom, x, frame.bottom + 6, INK),
                  _text(tick.label, x, frame.bottom + 9 + FONT_SIZE, anchor="middle")]
    for tick in y_scale.major:
        y = y_axis.position(tick.value)
        grid.append(_line(frame.left, y, frame.right, y, GRID))
        ticks += [_line(frame.left - 5, y, frame.left, y, INK),
                  _text(tick.label, frame.left - 9, y + BASELINE_DROP, anchor="end")]
    labels = [_text(title, width / 2, 8 + FONT_SIZE, anchor="middle"),
              _text(y_label, 8, frame.top - 12),
              _text(x_label, (frame.left + frame.right) / 2,
                    frame.bottom + 2 * FONT_SIZE + 22, anchor="middle")]

    lines, markers, drawn_xs, drawn_ys = [], [], [], []
    for one, (xs, ys) in zip(series, drawable):
        if not len(xs):
            continue
        columns, rows = x_axis.position(xs), y_axis.position(ys)
        points = " ".join(f"{_number(x)},{_number(y)}" for x, y in zip(columns, rows))
        lines.append(f'<polyline points="{points}" fill="none" stroke="{one.colour}" '
                     f'stroke-width="{LINE_WIDTH}" stroke-linejoin="round"/>')
        markers += [_marker(x, y, one.colour) for x, y in zip(columns, rows)]
        along_xs, along_ys = _points_along(columns, rows)
        drawn_xs.append(along_xs)
        drawn_ys.append(along_ys)

    legend = _legend(series, frame, np.concatenate(drawn_xs), np.concatenate(drawn_ys))
    frame_outline = (f'<rect class="frame" x="{_number(frame.left)}" y="{_number(frame.top)}" '
                     f'width="{_number(frame.right - frame.left)}" '
                     f'height="{_number(frame.bottom - frame.top)}" fill="none" '
                     f'stroke="{INK}"/>')
    body = grid + [frame_outline] + ticks + labels + lines + markers + legend
    return (f'<svg xmlns="http://www.w3.org/2000/svg" class="plot" width="{width}" '
            f'height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif" '
            f'font-size="{FONT_SIZE}" fill="{INK}">\n'
            f'<rect width="{width}" height="{height}" fill="white"/>\n'
            + "\n".join(body) + "\n</svg>\n")


def _points_along(xs, ys):
    """Points about a unit apart along the polyline through (xs, ys), its vertices included."""
    along_xs, along_ys = [xs[:1]], [ys[:1]]
    for x0, y0, x1, y1 in zip(xs[:-1], ys[:-1], xs[1:], ys[1:]):
        t = np.linspace(0, 1, int(math.hypot(x1 - x0, y1 - y0)) + 2)[1:]
        along_xs.append(x0 + t * (x1 - x0))
        along_ys.append(y0 + t * (y1 - y0))
    return np.concatenate(along_xs), np.concatenate(along_ys)


def _legend(series, frame, drawn_xs, drawn_ys):
    """A boxed key in whichever corner of the frame covers the least of the drawn lines."""
    line_height = FONT_SIZE + 7
    box_width = 46 + max(_text_width(one.label) for one in series)
    box_height = 8 + line_height * len(series)
    corners = [Box(left=x, top=y, right=x + box_width, bottom=y + box_height)
               for y in (frame.top + 8, frame.bottom - 8 - box_height)
               for x in (frame.right - 8 - box_width, frame.left + 8)]
    box = min(corners, key=lambda corner: corner.holds(drawn_xs, drawn_ys))
    parts = [f'<rect class="legend" x="{_number(box.left)}" y="{_number(box.top)}" '
             f'width="{_number(box_width)}" height="{_number(box_height)}" fill="white" '
             f'stroke="{INK}"/>']
    for index, one in enumerate(series):
        middle = box.top + 4 + line_height * (index + 0.5)
        parts += [_line(box.left + 8, middle, box.left + 30, middle, one.colour,
                        width=LINE_WIDTH),
                  _marker(box.left + 19, middle, one.colour),
                  _text(one.label, box.left + 38, middle + BASELINE_DROP)]
    return parts
