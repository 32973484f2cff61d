"""A small line-plot rasteriser in numpy that writes a PNG, for reports made inside Blender,
where matplotlib and PIL are not available. Text comes from a built-in 5x7 bitmap font."""
from dataclasses import dataclass
import math

import numpy as np

from .output import write_png

# 5x7 glyphs: seven rows of five bits each (bit 4 is the left column), as hex byte pairs.
# The rows of the descending letters start at the x-height, two rows lower than the rest.
_DESCENDERS = "gpqy"
_FONT_SOURCE = """
0 0e11131519110e 1 040c040404040e 2 0e11010204081f 3 1f02040201110e 4 02060a121f0202
5 1f101e0101110e 6 0608101e11110e 7 1f010204080808 8 0e11110e11110e 9 0e11110f01020c
A 0e11111f111111 B 1e11111e11111e C 0e11101010110e D 1c12111111121c E 1f10101e10101f
F 1f10101e101010 G 0e11101711110f H 1111111f111111 I 0e04040404040e J 0702020202120c
K 11121418141211 L 1010101010101f M 111b1515111111 N 11111915131111 O 0e11111111110e
P 1e11111e101010 Q 0e11111115120d R 1e11111e141211 S 0f10100e01011e T 1f040404040404
U 1111111111110e V 11111111110a04 W 1111111515150a X 11110a040a1111 Y 1111110a040404
Z 1f01020408101f a 00000e010f110f b 1010161911111e c 00000e1010110e d 01010d1311110f
e 00000e111f100e f 0609081c080808 g 0f1111110f010e h 10101619111111 i 04000c0404040e
j 0200060202120c k 10101214181412 l 0c04040404040e m 00001a15151111 n 00001619111111
o 00000e1111110e p 1e1111111e1010 q 0f1111110f0101 r 00001619101010 s 00000e100e011e
t 08081c08080906 u 0000111111130d v 00001111110a04 w 0000111115150a x 0000110a040a11
y 111111110f010e z 00001f0204081f . 00000000000c0c , 000000000c0408 - 0000001f000000
+ 0004041f040400 % 18190204081303 ( 02040808080402 ) 08040202020408 / 00010204081000
= 00001f001f0000 : 000c0c000c0c00 _ 0000000000001f ? 0e110102040004 ' 04040800000000
"""


def _parse_font(source):
    tokens = source.split()
    glyphs = {" ": np.zeros((9, 5), bool)}
    for character, digits in zip(tokens[0::2], tokens[1::2]):
        glyph = glyphs[character] = np.zeros((9, 5), bool)
        first_row = 2 if character in _DESCENDERS else 0
        for row in range(7):
            bits = int(digits[2 * row:2 * row + 2], 16)
            glyph[first_row + row] = [(bits >> (4 - column)) & 1 for column in range(5)]
    return glyphs


_GLYPHS = _parse_font(_FONT_SOURCE)
TEXT_SCALE = 2
TEXT_HEIGHT = 7 * TEXT_SCALE  # cap height; descenders hang below it
BACKGROUND, INK = (255, 255, 255), (40, 40, 40)
GRID, MINOR_GRID = (222, 222, 222), (240, 240, 240)


@dataclass
class Series:
    """One polyline: its legend label, data points and an RGB colour of 0..255 ints."""
    label: str
    xs: list
    ys: list
    colour: tuple


@dataclass(frozen=True)
class Axis:
    """Maps data to pixel coordinates: ``low`` lands on ``first_pixel`` and ``high`` on
    ``last_pixel``, proportionally to log10 of the value on a log axis. For the vertical
    axis first_pixel is the bottom row, so larger values land higher in the image."""
    low: float
    high: float
    log: bool
    first_pixel: int
    last_pixel: int

    def to_pixel(self, values):
        scale = np.log10 if self.log else np.asarray
        t = (scale(values) - scale(self.low)) / (scale(self.high) - scale(self.low))
        return self.first_pixel + t * (self.last_pixel - self.first_pixel)


def text_width(text):
    """Pixel width of ``text`` as draw_text draws it."""
    return max(len(text) * 6 - 1, 0) * TEXT_SCALE


def _paint(image, mask, top, left, colour):
    """Set the pixels where ``mask`` is true, placed at (top, left), clipped to the image."""
    height, width = image.shape[:2]
    rows = slice(max(top, 0), min(top + mask.shape[0], height))
    columns = slice(max(left, 0), min(left + mask.shape[1], width))
    clipped = mask[rows.start - top:rows.stop - top, columns.start - left:columns.stop - left]
    image[rows, columns][clipped] = colour


def draw_text(image, text, left, top, colour=INK):
    """Draw ``text`` with its top-left corner at (left, top); unknown characters show as ?."""
    glyphs = [_GLYPHS.get(character, _GLYPHS["?"]) for character in text]
    if not glyphs:
        return
    spaced = np.hstack([np.hstack([glyph, np.zeros((9, 1), bool)]) for glyph in glyphs])[:, :-1]
    mask = spaced.repeat(TEXT_SCALE, axis=0).repeat(TEXT_SCALE, axis=1)
    _paint(image, mask, int(top), int(left), colour)


def _rectangle(image, left, top, right, bottom, colour, filled=False):
    """Inclusive pixel bounds; an outline one pixel wide unless filled."""
    mask = np.ones((bottom - top + 1, right - left + 1), bool)
    if not filled:
        mask[1:-1, 1:-1] = False
    _paint(image, mask, top, left, colour)


def _polyline(image, xs, ys, colour, width=2.5):
    """Anti-aliased: coverage falls off over one pixel from the line's edge; the coverage of
    all segments is merged by maximum so the joints do not darken."""
    coverage = np.zeros(image.shape[:2])
    rows, columns = np.mgrid[0:image.shape[0], 0:image.shape[1]]
    reach = width / 2 + 1
    for x0, y0, x1, y1 in zip(xs[:-1], ys[:-1], xs[1:], ys[1:]):
        left, right = int(max(min(x0, x1) - reach, 0)), int(max(x0, x1) + reach) + 1
        top, bottom = int(max(min(y0, y1) - reach, 0)), int(max(y0, y1) + reach) + 1
        px, py = columns[top:bottom, left:right], rows[top:bottom, left:right]
        dx, dy = x1 - x0, y1 - y0
        t = np.clip(((px - x0) * dx + (py - y0) * dy) / max(dx * dx + dy * dy, 1e-12), 0, 1)
        distance = np.hypot(px - (x0 + t * dx), py - (y0 + t * dy))
        segment = np.clip(width / 2 + 0.5 - distance, 0, 1)
        np.maximum(coverage[top:bottom, left:right], segment,
                   out=coverage[top:bottom, left:right])
    blended = image * (1 - coverage[..., None]) + np.asarray(colour) * coverage[..., None]
    image[...] = np.round(blended).astype(np.uint8)


def _range_and_ticks(values, log):
    """Axis ends rounded out (to whole decades, or to a nice step) and the (major, minor)
    ticks between them, each major tick with its label."""
    low, high = float(np.min(values)), float(np.max(values))
    if log:
        first, last = math.floor(math.log10(low)), math.ceil(math.log10(high))
        if first == last:
            first, last = first - 1, last + 1
        stride = math.ceil((last - first) / 8)
        major = [(10.0 ** k, _decade_label(k)) for k in range(first, last + 1, stride)]
        # Unlabelled 2..9 ticks only while they do not crowd the axis.
        minor = ([m * 10.0 ** k for k in range(first, last) for m in range(2, 10)]
                 if last - first <= 6 else [])
        return 10.0 ** first, 10.0 ** last, major, minor
    span = high - low or abs(high) or 1.0
    exponent = math.floor(math.log10(span / 5))
    step = min((m * 10.0 ** exponent for m in (1, 2, 5, 10) if m * 10.0 ** exponent >= span / 5))
    first, last = math.floor(low / step), math.ceil(high / step)
    if first == last:
        first, last = first - 1, last + 1
    decimals = max(0, -math.floor(math.log10(step)))
    major = [(k * step, f"{k * step:.{decimals}f}") for k in range(first, last + 1)]
    return first * step, last * step, major, []


def _decade_label(exponent):
    return f"{10.0 ** exponent:.{max(0, -exponent)}f}" if -3 <= exponent <= 4 else f"1e{exponent}"


def line_plot(path, series, x_label, y_label, title="", log_x=True, log_y=True,
              size=(720, 460)):
    """Draw ``series`` (a list of Series) into a ``size`` = (width, height) PNG at ``path``.
    Points that are not finite, or not positive on a log axis, are skipped; a series left
    with none is listed in the legend but not drawn. Returns the (x, y) Axis mappings used.
    Raises ValueError if no series has a point to draw."""
    width, height = size
    drawable = []
    for one in series:
        xs, ys = np.asarray(one.xs, float).ravel(), np.asarray(one.ys, float).ravel()
        keep = np.isfinite(xs) & np.isfinite(ys)
        keep &= (xs > 0 if log_x else True) & (ys > 0 if log_y else True)
        drawable.append((xs[keep], ys[keep]))
    if not any(len(xs) for xs, _ in drawable):
        raise ValueError("no series has a finite point to plot"
                         + (" (log axes need positive values)" if log_x or log_y else ""))
    x_low, x_high, x_major, x_minor = _range_and_ticks(
        np.concatenate([xs for xs, _ in drawable]), log_x)
    y_low, y_high, y_major, y_minor = _range_and_ticks(
        np.concatenate([ys for _, ys in drawable]), log_y)

    left = max(text_width(label) for _, label in y_major) + 16
    right, top, bottom = width - 32, 2 * TEXT_HEIGHT + 28, height - 2 * TEXT_HEIGHT - 26
    x_axis = Axis(x_low, x_high, log_x, left, right)
    y_axis = Axis(y_low, y_high, log_y, bottom, top)
    image = np.full((height, width, 3), BACKGROUND, np.uint8)

    for value in x_minor:
        image[top:bottom, int(round(x_axis.to_pixel(value)))] = MINOR_GRID
    for value in y_minor:
        image[int(round(y_axis.to_pixel(value))), left:right] = MINOR_GRID
    for value, label in x_major:
        column = int(round(x_axis.to_pixel(value)))
        image[top:bottom, column] = GRID
        image[bottom:bottom + 6, column] = INK
        draw_text(image, label, column - text_width(label) // 2, bottom + 9)
    for value, label in y_major:
        row = int(round(y_axis.to_pixel(value)))
        image[row, left:right] = GRID
        image[row, left - 5:left] = INK
        draw_text(image, label, left - 9 - text_width(label), row - TEXT_HEIGHT // 2)
    _rectangle(image, left, top, right, bottom, INK)
    draw_text(image, title, (width - text_width(title)) // 2, 8)
    draw_text(image, y_label, 8, top - TEXT_HEIGHT - 10)
    draw_text(image, x_label, (left + right - text_width(x_label)) // 2, bottom + TEXT_HEIGHT + 16)

    before_series = image.copy()
    for one, (xs, ys) in zip(series, drawable):
        columns, rows = x_axis.to_pixel(xs), y_axis.to_pixel(ys)
        _polyline(image, columns, rows, one.colour)
        for column, row in zip(np.round(columns).astype(int), np.round(rows).astype(int)):
            _rectangle(image, column - 3, row - 3, column + 3, row + 3, one.colour, filled=True)

    series_pixels = (image != before_series).any(axis=2)
    _legend(image, series, (left, top, right, bottom), series_pixels)
    write_png(path, image)
    return x_axis, y_axis


def _legend(image, series, frame, series_pixels):
    """A boxed key in whichever corner of the frame covers the fewest series pixels."""
    left, top, right, bottom = frame
    line_height = TEXT_HEIGHT + 6
    box_width = 46 + max(text_width(one.label) for one in series)
    box_height = 8 + line_height * len(series)
    corners = [(x, y) for y in (top + 8, bottom - 8 - box_height)
               for x in (right - 8 - box_width, left + 8)]
    x, y = min(corners, key=lambda corner: series_pixels[
        corner[1]:corner[1] + box_height, corner[0]:corner[0] + box_width].sum())
    _rectangle(image, x, y, x + box_width, y + box_height, BACKGROUND, filled=True)
    _rectangle(image, x, y, x + box_width, y + box_height, INK)
    for index, one in enumerate(series):
        row = y + 5 + index * line_height
        middle = row + TEXT_HEIGHT // 2
        _rectangle(image, x + 8, middle - 1, x + 30, middle, one.colour, filled=True)
        _rectangle(image, x + 16, middle - 3, x + 22, middle + 3, one.colour, filled=True)
        draw_text(image, one.label, x + 38, row)
