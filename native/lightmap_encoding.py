"""Lightmaps as 8-bit PNGs that engines and browsers decode: RGBD, as Babylon.js stores HDR in
PNGs (its textures' isRGBD), scaled per page.

A texel's light ``value`` (any linear unit) is ``intensity * (rgb ** GAMMA) / d`` with rgb and
d its four bytes over 255. ``intensity`` (one number per page, glTF's MOZ_lightmap
``intensity``) maps the page's brightest texel to RGBD_RANGE; d is as large as keeps rgb * d
within 1, so each texel spends the rgb bytes on its own brightness: about 0.5 % steps above
1/255 of the page's brightest texel, and the gamma curve's below."""
from dataclasses import dataclass

import numpy as np

from .output import png_bytes

GAMMA = 2.2
RGBD_RANGE = 255.0
ENCODING = "RGBD"


@dataclass(frozen=True)
class EncodedLightmap:
    """A page as PNG bytes (top row first: glTF's v runs down the image) and its scale."""
    png: bytes
    intensity: float


def encode_rgbd(light):
    """(H, W, >= 3) linear values -> ((H, W, 4) uint8 RGBD in the same row order, intensity)."""
    rgb = np.nan_to_num(np.asarray(light, dtype=np.float64)[..., :3], nan=0.0, posinf=0.0)
    rgb = np.maximum(rgb, 0.0)
    brightest = float(rgb.max(initial=0.0))
    intensity = brightest / RGBD_RANGE if brightest > 0.0 else 1.0
    value = rgb / intensity
    largest = value.max(axis=-1)
    divisor = np.clip(np.floor(RGBD_RANGE / np.maximum(largest, 1e-30)), 1.0, 255.0)
    scaled = np.clip(value * (divisor / 255.0)[..., None], 0.0, 1.0)
    encoded = np.empty(rgb.shape[:-1] + (4,), dtype=np.uint8)
    encoded[..., :3] = np.round(255.0 * scaled ** (1.0 / GAMMA))
    encoded[..., 3] = divisor
    return encoded, intensity


def decode_rgbd(encoded, intensity):
    """Inverse of encode_rgbd: (H, W, 4) uint8 -> (H, W, 3) float64 linear values."""
    encoded = np.asarray(encoded, dtype=np.float64) / 255.0
    return intensity * encoded[..., :3] ** GAMMA / np.maximum(encoded[..., 3:4], 1.0 / 255.0)


def lightmap_png(light):
    """A page (H, W, >= 3), row 0 at v = 0 as in Blender, as an EncodedLightmap."""
    encoded, intensity = encode_rgbd(light)
    return EncodedLightmap(png=png_bytes(np.flipud(encoded)), intensity=intensity)
