"""The memory budget: how much GPU memory an atlas's maps take, and the refusal, with a
density that fits, of an atlas over Settings.memory_limit or the largest texture size; and
of a visibility map larger than one texture may hold."""
import math

import numpy as np

from . import lobes
from .atlas import charted_triangles
from .errors import GPUMemoryError, SettingsError
from .state import LEAST_SUN_TILES

# Per texel (see preprocess.allocate_page): position + area, irradiance, unshot radiance +
# texel size, and what a receiver pass gathered before it is added (RGBA32F, 16 B each: sums
# over thousands of shots), the area whose received light is the texel's own (R32F, 4 B),
# albedo + surface number
# (RGBA16, 8 B: 16-bit fixed point holds 0.99 within 8e-6, where half floats' 0.99023 put
# 2.4 % more light in a closed room of that albedo), the octahedral normal, its spread and
# spread axis (RGBA16, 8 B) and the subdivision level (R8, 1 B). The rasterization depth
# (4 B) and the albedo the lightmaps show (RGBA16, 8 B, read to the CPU) live only until the
# irradiance is made.
BYTES_PER_TEXEL = 4 * 16 + 4 + 8 + 8 + 1
# And where the scene's glossy layers leave in lobes (lobes.needed), the directions the unshot
# light came in from and those a receiver pass gathered (RGBA32F: sums as the unshot
# radiance).
LOBE_BYTES_PER_TEXEL = 2 * 16
# The selection pyramid's first level holds a texel (RGBA32F) per block; the levels above
# it add a third.
PYRAMID_TEXEL_BYTES = 16
# The visibility map: per texel of each layer the distance and the surface key (RG32F), a
# layer per cube face (per face of each shooter of a batch) or per hemisphere.
VISIBILITY_BYTES_PER_TEXEL = 2 * 4
# The most shooters one receiver pass gathers.
MOST_BATCHED_SHOOTERS = 8
# The most bytes one texture may hold: llvmpipe leaves the framebuffer of a 1.5 GiB texture
# incomplete, and a driver bounds one allocation below its whole memory.
MAX_TEXTURE_BYTES = 1 << 30
# A search for a density that fits steps down by this factor, at most this many times.
DENSITY_STEP = 0.85
DENSITY_STEPS = 30
# A first guess starts from this share of the memory for the surface: charts are padded and
# packed with gaps.
SURFACE_SHARE_GUESS = 0.5


def bytes_per_texel(scene):
    """The maps' bytes per texel for ``scene``."""
    return BYTES_PER_TEXEL + (LOBE_BYTES_PER_TEXEL if lobes.needed(scene) else 0)


def memory_needed(atlas, settings, map_size, batch=1, *, texel_bytes=BYTES_PER_TEXEL):
    """Bytes of the maps of ``atlas``'s pages (``texel_bytes`` a texel: bytes_per_texel),
    its selection pyramid and the visibility map of a receiver pass of ``batch``
    shooters."""
    texels = atlas.width * atlas.height * atlas.page_count
    block = 1 << settings.shoot_level
    pyramid = texels / (block * block) * PYRAMID_TEXEL_BYTES * 4 / 3
    return int(texels * texel_bytes + pyramid + visibility_bytes(settings, map_size, batch))


def visibility_bytes(settings, map_size, batch):
    """Bytes of the visibility map of a receiver pass of ``batch`` shooters: one texture."""
    return map_size ** 2 * visibility_layers(settings, batch) * VISIBILITY_BYTES_PER_TEXEL


def visibility_layers(settings, batch):
    """The visibility map's layers: a hemicube's six faces per shooter of the batch (a
    light's view all round takes six too), or for the hemisphere projections the more of
    their two and a sun's least tiles. A sun's window takes as many as its tiles
    (preprocess.sun_tiles)."""
    return 6 * batch if settings.projection == "HEMICUBE" else max(2, LEAST_SUN_TILES ** 2)


def sun_batch(layers, tiles, receiver_batch):
    """Suns one receiver pass gathers: as many windows of ``tiles`` x ``tiles`` as the map's
    ``layers`` hold, at most the receiver batch."""
    return max(1, min(receiver_batch, layers // tiles ** 2))


def receiver_batch(atlas, settings, map_size, *, texel_bytes=BYTES_PER_TEXEL):
    """How many shooters one receiver pass gathers: those of a selection, at most
    MOST_BATCHED_SHOOTERS, as many as the memory limit leaves room for their visibility maps
    and one texture holds.
    One with Settings.batched_receivers off, with a hemisphere projection (the batch's maps
    are hemicubes) and with adaptive subdivision (which tests each shot's shadows against its
    map before the receivers gather it)."""
    if (not settings.batched_receivers or settings.projection != "HEMICUBE"
            or settings.subdivision == "ADAPTIVE"):
        return 1
    batch = min(settings.shooters_per_selection, MOST_BATCHED_SHOOTERS)
    while batch > 1 and (memory_needed(atlas, settings, map_size, batch,
                                       texel_bytes=texel_bytes) > settings.memory_limit
                         or visibility_bytes(settings, map_size, batch) > MAX_TEXTURE_BYTES):
        batch -= 1
    return batch


def check_visibility_map(settings, map_size):
    """Refuse a Hemicube Resolution whose visibility map, for one shooter, is larger than
    one texture may hold (no texel density changes it), naming the largest that fits."""
    needed = visibility_bytes(settings, map_size, 1)
    if needed <= MAX_TEXTURE_BYTES:
        return
    resolution = settings.hemicube_resolution
    scale = map_size // resolution
    while resolution > 1 and visibility_bytes(settings, resolution * scale, 1) > MAX_TEXTURE_BYTES:
        resolution //= 2
    raise SettingsError(
        f"Hemicube Resolution {settings.hemicube_resolution} makes a visibility map of "
        f"{needed / 2**20:,.0f} MiB, more than one GPU texture may hold "
        f"({MAX_TEXTURE_BYTES / 2**20:,.0f} MiB): set it to {resolution} or lower, or to 0 "
        f"(automatic)")


def fits(atlas, settings, map_size, max_texture_size, *, texel_bytes=BYTES_PER_TEXEL):
    """Whether the atlas fits, with a receiver pass of one shooter at least."""
    return (memory_needed(atlas, settings, map_size, texel_bytes=texel_bytes)
            <= settings.memory_limit
            and max(atlas.width, atlas.height) <= max_texture_size)


def check_surface_fits(scene, settings, fits_at):
    """Refuse, before xatlas charts it, a density whose surface alone overflows the memory:
    at 10^4 texels per metre xatlas takes 100 s on a 4 m room, at 10^6 hours. ``fits_at``
    tells whether the atlas of a density fits."""
    density = settings.texel_density
    if not np.isfinite(density) or density <= 0.0:
        return  # build_atlas names the bad value
    charted = charted_triangles(scene)
    scales = np.asarray(scene.object_texel_scale)[scene.object_index[charted]]
    surface = float(np.sum(scene.triangle_area[charted] * scales ** 2))  # m^2 at density 1
    texel_bytes = bytes_per_texel(scene)
    needed = surface * density ** 2 * texel_bytes
    limit = int(settings.memory_limit)
    if needed <= limit:
        return
    fits = density_that_fits(
        math.sqrt(SURFACE_SHARE_GUESS * limit / (surface * texel_bytes)), fits_at)
    raise GPUMemoryError(
        f"the lightmaps need at least {needed / 2**20:,.0f} MiB of GPU memory at "
        f"{density:.4g} texels per metre but {limit / 2**20:.1f} MiB are allowed: "
        f"{lower_to(fits)}", int(needed), limit, fits)


def check_memory(atlas, settings, needed, fitting, fits_at):
    """Refuse an atlas that does not fit (``fitting`` False) and needs ``needed`` bytes."""
    if fitting:
        return
    # Texels scale with the square of the density; padding does not, so search down.
    limit = int(settings.memory_limit)
    fits = density_that_fits(atlas.density * math.sqrt(limit / needed), fits_at)
    raise GPUMemoryError(
        f"the lightmaps need {needed / 2**20:.1f} MiB of GPU memory "
        f"({atlas.width}x{atlas.height} texels on {atlas.page_count} page(s)) but "
        f"{limit / 2**20:.1f} MiB are allowed: {lower_to(fits, atlas.density)}",
        needed, limit, fits)


def density_that_fits(density, fits_at):
    """The first density from ``density`` down in steps of 15 % whose atlas fits, or None
    when even 1/130 of it does not."""
    for _ in range(DENSITY_STEPS):
        if fits_at(density):
            return density
        density *= DENSITY_STEP
    return None


def lower_to(density, current=None):
    """The fix a GPUMemoryError gives: a density checked to fit, or the memory to raise."""
    if density is None:
        return ("no texel density fits: raise the memory limit or give fewer objects a "
                "lightmap")
    start = "" if current is None else f"from {current:.4g} "
    return f"lower the texel density {start}to {density:.4g} texels per metre or less"
