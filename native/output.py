"""Writing lightmaps: float32 OpenEXR through the OpenEXR package, and a tone-mapped PNG
preview. Files are written under a temporary name and renamed, so a failed write never leaves
a half-written file under the final name."""
import os
from pathlib import Path
import struct
import tempfile
import zlib

import numpy as np
import OpenEXR


def _atomic_write(path, write):
    path = Path(path)
    handle, temporary = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=path.suffix,
                                         dir=path.parent)
    os.close(handle)
    try:
        write(temporary)
        # mkstemp makes the file private; give it the permissions a plain open() would.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(temporary, 0o666 & ~umask)
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise


def write_exr(path, image):
    """Write an (H, W, 4) float32 lightmap, row 0 at v = 0, as an RGBA float EXR (top row
    first, as image viewers and Blender expect)."""
    pixels = np.ascontiguousarray(np.flipud(np.asarray(image, dtype=np.float32)))
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    channels = {"RGBA": pixels}
    _atomic_write(path, lambda name: OpenEXR.File(header, channels).write(name))


def read_exr(path):
    """Inverse of write_exr: (H, W, 4) float32 with row 0 at v = 0."""
    with OpenEXR.File(str(path)) as exr:
        channels = exr.channels()
        pixels = channels["RGBA"].pixels if "RGBA" in channels else np.dstack(
            [channels[c].pixels for c in "RGBA"])
    return np.flipud(np.asarray(pixels, dtype=np.float32)).copy()


def tone_map(image, exposure=1.0):
    """Linear radiance to 8-bit sRGB: exposure, Reinhard on luminance, sRGB curve."""
    rgb = np.asarray(image, dtype=np.float64)[..., :3] * exposure
    luminance = rgb @ np.array([0.2126, 0.7152, 0.0722])
    rgb = rgb / (1.0 + luminance[..., None])
    srgb = np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * np.power(np.maximum(rgb, 0), 1 / 2.4) - 0.055)
    return np.clip(np.round(srgb * 255.0), 0, 255).astype(np.uint8)


def write_bytes(path, data):
    """``data`` into the file at ``path``, whole or not at all."""
    _atomic_write(path, lambda name: Path(name).write_bytes(data))


def write_png(path, rgb8):
    """Minimal PNG writer for an (H, W, 3) or (H, W, 4) uint8 image, top row first."""
    write_bytes(path, png_bytes(rgb8))


def png_bytes(image8):
    """An (H, W, 3) RGB or (H, W, 4) RGBA uint8 image, top row first, as a PNG file's bytes."""
    height, width, channels = image8.shape
    raw = b"".join(b"\x00" + row.tobytes() for row in np.ascontiguousarray(image8))

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    colour_type = {3: 2, 4: 6}[channels]
    return (b"\x89PNG\r\n\x1a\n"
            + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, colour_type, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
