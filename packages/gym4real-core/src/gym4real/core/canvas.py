"""The drawing surface of every ``render_mode="rgb_array"`` frame: boxes, lines, series, gauges and text.

One small layer over Pillow's ``ImageDraw`` (compiled drawing, a few microseconds a primitive) with
Pillow's bitmap font (6 x 11 pixels a character, crisp at any frame size, few colours: small GIFs).
A renderer draws what never changes (axes, labels, thresholds) once on a :class:`Canvas`, then each
frame on a :meth:`Canvas.copy` of it, and returns :meth:`Canvas.array`.

    >>> canvas = Canvas(64, 32)
    >>> canvas.text((2, 2), "SoC 42%")
    >>> canvas.array().shape
    (32, 64, 3)
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np
from PIL import Image, ImageDraw, ImageFont

Colour = tuple[int, int, int]
Box = tuple[float, float, float, float]

WHITE: Colour = (255, 255, 255)
INK: Colour = (30, 30, 30)
GREY: Colour = (150, 150, 150)
LIGHT: Colour = (225, 225, 225)
BLUE: Colour = (40, 110, 220)
WATER: Colour = (120, 170, 235)
RED: Colour = (210, 40, 40)
ORANGE: Colour = (235, 140, 20)
GREEN: Colour = (40, 160, 60)
PURPLE: Colour = (130, 60, 170)

#: Width and height of one character of the font, in pixels (at ``scale=1``).
CHAR_WIDTH, CHAR_HEIGHT = 6, 11


@functools.cache
def _font() -> ImageFont.ImageFont:
    return ImageFont.load_default_imagefont()


class Canvas:
    """An RGB picture to draw on; coordinates are pixels from the top-left corner.

    Args:
        width: Width in pixels.
        height: Height in pixels.
        background: Colour the canvas starts with.
    """

    def __init__(self, width: int, height: int, background: Colour = WHITE) -> None:
        self.image = Image.new("RGB", (width, height), background)
        self._draw = ImageDraw.Draw(self.image)

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in pixels."""
        return self.image.size

    def copy(self) -> Canvas:
        """A new canvas holding this one's picture (draw the static part once, copy it per frame)."""
        other = Canvas.__new__(Canvas)
        other.image = self.image.copy()
        other._draw = ImageDraw.Draw(other.image)
        return other

    def array(self) -> np.ndarray:
        """The picture as an ``H x W x 3`` uint8 array (a new array)."""
        return np.array(self.image)

    def box(self, xy: Box, fill: Colour | None = None, outline: Colour | None = None, width: int = 1) -> None:
        """A rectangle from (x0, y0) to (x1, y1), corners included; nothing when it is empty."""
        x0, y0, x1, y1 = xy
        if x1 < x0 or y1 < y0:
            return
        self._draw.rectangle((x0, y0, x1, y1), fill=fill, outline=outline, width=width)

    def line(self, points: Sequence[tuple[float, float]], fill: Colour, width: int = 1) -> None:
        """A polyline through ``points``."""
        if len(points) > 1:
            self._draw.line(list(points), fill=fill, width=width)

    def dashed(self, y: float, x0: float, x1: float, fill: Colour, dash: int = 4) -> None:
        """A horizontal dashed line at height ``y`` from ``x0`` to ``x1``."""
        for x in range(int(x0), int(x1), 2 * dash):
            self._draw.line([(x, y), (min(x + dash - 1, x1), y)], fill=fill)

    def disc(self, centre: tuple[float, float], radius: float, fill: Colour, outline: Colour | None = None) -> None:
        """A filled circle."""
        x, y = centre
        self._draw.ellipse((x - radius, y - radius, x + radius, y + radius), fill=fill, outline=outline)

    def polygon(self, points: Sequence[tuple[float, float]], fill: Colour) -> None:
        """A filled polygon."""
        self._draw.polygon(list(points), fill=fill)

    def arrow(self, start: tuple[float, float], end: tuple[float, float], fill: Colour, width: int = 2) -> None:
        """A straight arrow from ``start`` to ``end`` with a head of a size that follows ``width``."""
        (x0, y0), (x1, y1) = start, end
        length = float(np.hypot(x1 - x0, y1 - y0))
        if length < 1:
            return
        ux, uy = (x1 - x0) / length, (y1 - y0) / length
        head = min(3.0 + 2.0 * width, length)
        bx, by = x1 - ux * head, y1 - uy * head
        self._draw.line([(x0, y0), (bx, by)], fill=fill, width=width)
        half = head * 0.6
        self.polygon([(x1, y1), (bx - uy * half, by + ux * half), (bx + uy * half, by - ux * half)], fill)

    def text(self, xy: tuple[float, float], text: str, fill: Colour = INK, align: str = "left", scale: int = 1) -> None:
        """Text whose top is at ``xy[1]`` and whose left, centre or right (``align``) is at ``xy[0]``.

        ``scale`` enlarges the characters by a whole factor (pixel-doubled).
        """
        width = len(text) * CHAR_WIDTH * scale
        x = xy[0] - (width if align == "right" else width / 2 if align == "center" else 0)
        x, y = round(x), round(xy[1])
        if scale == 1:
            self._draw.text((x, y), text, fill=fill, font=_font())
            return
        mask = Image.new("L", (len(text) * CHAR_WIDTH, CHAR_HEIGHT), 0)
        ImageDraw.Draw(mask).text((0, 0), text, fill=255, font=_font())
        mask = mask.resize((mask.width * scale, mask.height * scale), Image.Resampling.NEAREST)
        self.image.paste(fill, (x, y, x + mask.width, y + mask.height), mask)

    def series(
        self, xy: Box, values: Sequence[float], span: tuple[float, float], n: int, fill: Colour, width: int = 1
    ) -> None:
        """Plot ``values[i]`` at ``i`` of ``n`` slots across the box, ``span = (low, high)`` bottom to top.

        Values beyond the span are drawn at the box's edge; of more values than pixels, every k-th is
        drawn (and the last).
        """
        if len(values) < 2:
            return
        x0, y0, x1, y1 = xy
        low, high = span
        index = np.arange(len(values))
        stride = len(values) // max(int(x1 - x0), 1)
        if stride > 1:
            index = np.append(index[:-1:stride], len(values) - 1)
        ys = np.asarray(values, dtype=np.float64)[index]
        ys = np.clip((ys - low) / ((high - low) or 1.0), 0.0, 1.0)
        xs = x0 + index * ((x1 - x0) / max(n - 1, 1))
        self._draw.line(list(zip(xs.tolist(), (y1 - ys * (y1 - y0)).tolist(), strict=True)), fill=fill, width=width)

    def gauge(
        self,
        xy: Box,
        fraction: float,
        fill: Colour,
        vertical: bool = True,
        marks: Sequence[tuple[float, Colour]] = (),
    ) -> None:
        """A framed bar filled to ``fraction`` (clipped to [0, 1]) from the bottom (or the left).

        ``marks`` are (fraction, colour) lines across the bar, such as thresholds.
        """
        x0, y0, x1, y1 = xy
        f = min(max(fraction, 0.0), 1.0) if fraction == fraction else 0.0
        self.box(xy, fill=LIGHT)
        if vertical:
            self.box((x0, y1 - f * (y1 - y0), x1, y1), fill=fill)
        else:
            self.box((x0, y0, x0 + f * (x1 - x0), y1), fill=fill)
        for m, colour in marks:
            m = min(max(m, 0.0), 1.0)
            if vertical:
                y = y1 - m * (y1 - y0)
                self._draw.line([(x0 - 3, y), (x1 + 3, y)], fill=colour, width=2)
            else:
                x = x0 + m * (x1 - x0)
                self._draw.line([(x, y0 - 3), (x, y1 + 3)], fill=colour, width=2)
        self.box(xy, outline=INK)


def captioned(frame: np.ndarray, lines: Sequence[str], min_width: int = 360, max_height: int = 480) -> np.ndarray:
    """A frame under a band of text lines (a video's title): ``H' x W' x 3`` uint8 with even sides.

    A frame narrower than ``min_width`` is enlarged by a whole factor (pixel-doubled), as far as it stays
    within ``max_height``; one narrower than the longest line is centred on a white strip; odd sides get a
    white pixel row or column (video codecs need even sides).
    """
    if frame.ndim != 3 or frame.shape[2] != 3 or frame.dtype != np.uint8:
        raise ValueError(f"a frame must be an H x W x 3 uint8 array, got {frame.dtype} of shape {frame.shape}")
    factor = max(1, min(-(-min_width // frame.shape[1]), max_height // frame.shape[0]))
    if factor > 1:
        frame = frame.repeat(factor, axis=0).repeat(factor, axis=1)
    h, w = frame.shape[:2]
    band = 6 + (CHAR_HEIGHT + 2) * len(lines)
    width = max(w, 12 + CHAR_WIDTH * max((len(s) for s in lines), default=0))
    width += width % 2
    height = band + h + (band + h) % 2
    canvas = Canvas(width, height)
    for i, text in enumerate(lines):
        canvas.text((6, 4 + (CHAR_HEIGHT + 2) * i), text)
    canvas.box((0, band - 1, width - 1, band - 1), fill=LIGHT)
    out = canvas.array()
    x = (width - w) // 2
    out[band : band + h, x : x + w] = frame
    return out
