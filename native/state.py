"""The state the solver's stages share: one bake's GPU objects and per-page maps (BakeState,
Page), the scene's bounding sphere, the visibility map, the energy totals, and the records
that travel from stage to stage (Region, Shooter, View). Each stage module takes these as
arguments; none of them imports another stage."""
from dataclasses import dataclass, field
import math

import moderngl
import numpy as np

from .geometry import tangents_of
from .gpu import render_state, set_uniform

# The octahedral normal's steps each way of 0 in its 16-bit channels (texel_maps.glsl).
OCT_STEPS = 32767.0
# A bent texel's axis and tilt (preprocess.bent_normal_codes) take 8 bits each of one 16-bit
# channel.
BEND_STEPS = 255
# A surface rectangle (u min, u max, v min, v max) that holds no point.
NO_SURFACE = (1e30, -1e30, 1e30, -1e30)
# Texture units of the maps the receiver passes read (receiver_common.glsl, then
# gathered_power.vert and deliver.frag), and of the visibility map on 0.
MAP_UNITS = {"position": 1, "normal": 2, "material": 3, "level": 4, "gathered": 5,
             "gathered_incoming": 6, "own_area": 8}
# And of a pass's totals, which deliver.frag reads (receivers.update).
TOTAL_UNITS = {"received": 0, "reflected": 7}
# The sun's orthographic window is cut into sun_tiles x sun_tiles faces of the visibility
# map (projection.glsl, preprocess.sun_tiles), from LEAST_SUN_TILES to MOST_SUN_TILES a
# side: a level's window spans hundreds of metres.
LEAST_SUN_TILES = 2
MOST_SUN_TILES = 4


@dataclass
class Page:
    """One page of the packed atlas on the GPU: its maps (textures, by name) and the
    framebuffers that write them."""
    blocks: object          # framebuffer: position, normal, unshot, material, incoming
                            # (read back per shooter)
    unshot_only: object     # framebuffer: unshot
    incoming_only: object   # framebuffer: incoming (receiver_common.glsl out_incoming), or
                            # None where the scene needs no lobes
    area_only: object       # framebuffer: position (area in .w)
    level_only: object      # framebuffer: subdivision level
    textures: dict
    pyramid: list = field(default_factory=list)   # (texture, framebuffer) from block level to 1x1
    receivers: object = None   # framebuffer: irradiance, unshot (made after rasterization)
    # framebuffer: what a receiver pass gathered (irradiance, and incoming directions where
    # the scene keeps them), before receivers.update adds it to the maps
    gather: object = None
    # Where the page's texels holding surface sit in Solver.atlas's page of the same number:
    # flat indices here and there (in_atlas_layout).
    to_atlas: tuple = None
    # Emitting texels not yet shot: flat texel indices (sorted) and their emitted power (W),
    # zeroed as they shoot (the ambient term leaves direct light out).
    emission_left: tuple = (np.zeros(0, np.int64), np.zeros((0, 3)))
    area: np.ndarray = None    # (H, W) float32: each texel's area, m^2 (it does not change)
    # (H, W) float32: the share of a texel's area that is its own, less where faces drawn
    # over each other share it (buried.py): what it receives counts at that share. None: 1.
    share: np.ndarray = None
    # (H, W, 3) float32: the diffuse albedo the lightmap shows (the material map holds what
    # the texel reflects into the room, more where glossy layers reflect too)
    albedo: np.ndarray = None
    roughness: np.ndarray = None   # (H, W) float32: its glossy layers' (Scene.roughness)

    def own_area(self):
        """Per texel the area whose received light is its own (share)."""
        return self.area if self.share is None else self.area * self.share

    def use_maps(self, *names):
        """Bind the named maps to their units (MAP_UNITS)."""
        for name in names:
            self.textures[name].use(location=MAP_UNITS[name])


@dataclass
class Bounds:
    """The scene's bounding sphere, and the depth tolerance scaled to it."""
    centre: np.ndarray
    radius: float
    epsilon: float


@dataclass
class BakeState:
    """What every stage of one bake works on."""
    ctx: object
    gl: object                  # gpu.GLObjects: every GL object goes through it
    scene: object
    settings: object
    bounds: Bounds
    map_size: int               # the visibility map's side in texels
    surfaces: np.ndarray        # per triangle its surface number (1..SURFACE_NUMBERS)
    emitting_surfaces: int      # surfaces 1..this emit
    atlas: object = None        # the lightmaps' layout (Solver.atlas)
    packed: object = None       # the charts packed tight: the pages the GPU works on
    texel_map: object = None    # packed page texels -> atlas texels (packing.tight_packing)
    patch_level: int = 0        # the mip level whose blocks shoot (selection.patch_level)
    receiver_tiles: object = None  # receivers.ReceiverTiles: what the receiver pass draws
    programs: dict = None
    per_face_visibility: bool = False   # the cube drawn face by face (preprocess.draws_per_face)
    receiver_batch: int = 1     # shooters per receiver pass (memory.receiver_batch)
    sun_tiles: int = LEAST_SUN_TILES   # a side of the sun's window (preprocess.sun_tiles)
    sun_batch: int = 1          # suns per receiver pass (memory.sun_batch)
    glossy: bool = False        # some texels reflect through glossy layers (lobes.has_glossy)
    glossy_lobes: bool = False  # the pages keep incoming directions (lobes.needed)
    fullscreen: dict = None     # vertex arrays drawing one screen-filling triangle
    material_textures: dict = None   # Scene's texture lists, by name, on the GPU
    pages: list = None
    points_vbo: object = None   # one point per texel a shot changes in place (blend_points)
    points_vao: object = None

    @property
    def sun_faces(self):
        """The visibility map's layers one sun's window takes."""
        return self.sun_tiles ** 2


@dataclass
class Energy:
    """Power totals (W, RGB, double precision) and the texel counts the stages measure by."""
    emitted_maps: np.ndarray    # what the emitting texels hold
    texel_count: int            # receiving texels
    shooting_blocks: int        # patches (blocks at the patch level) holding texels
    # The most any receiving texel reflects into the room (RGB): a shot adds at most this
    # share of its power to the unshot power (receivers.unshot_limit).
    largest_reflectance: np.ndarray = field(default_factory=lambda: np.zeros(3))
    emitted: np.ndarray = None  # the texels' and the lights'
    emitted_scalar: float = 0.0
    shot_power: np.ndarray = field(default_factory=lambda: np.zeros(3))
    # What shooters sent beyond what their texels held (lobes.reflect: glossy layers reflect
    # more of slanting light than the material map says): not absorbed.
    reflected_surplus: np.ndarray = field(default_factory=lambda: np.zeros(3))
    # A sun shoots over the scene's bounding square: what misses the scene (three times what
    # lands, on the temple's ground) is emitted for the ledger but not left for the threshold
    # to wait on.
    sunlight_missed: float = 0.0


@dataclass
class VisibilityMap:
    """The distance map a shot's visibility is drawn into, and the occluders drawn."""
    texture: object
    framebuffer: object
    vaos: dict                  # per visibility program
    triangle_vertices: int
    occluders: object           # geometry.TrianglePlanes of the occluding triangles
    caster_levels: np.ndarray   # per occluder its subdivision level (tessellated hemisphere)
    caster_vbo: object
    cluster_low: np.ndarray     # (C, 3) bounds of each cluster of occluders (visibility.py)
    cluster_high: np.ndarray
    covered: object             # a row of a pixel per map of a batch: the texels drawn into
    covered_framebuffer: object  # its first layer (visibility.covered_shares)


@dataclass(frozen=True)
class Region:
    """A square of texels on a page: a shooting block, or a part of one."""
    page: int
    x0: int
    y0: int
    size: int

    def overlaps(self, other):
        """Whether the two squares share a texel."""
        return (self.page == other.page and self.x0 < other.x0 + other.size
                and other.x0 < self.x0 + self.size and self.y0 < other.y0 + other.size
                and other.y0 < self.y0 + self.size)

    def width_on(self, packed):
        """The texels across, cut at the page's edge."""
        return min(self.size, packed.width - self.x0)

    def height_on(self, packed):
        return min(self.size, packed.height - self.y0)


@dataclass
class View:
    """Where the visibility map was drawn from: an eye and its frame (columns t, b, n), and
    whether the projection is orthographic (the sun)."""
    eye: np.ndarray
    frame: np.ndarray
    orthographic: bool

    def set_uniforms(self, program, state):
        """The view's uniforms (projection.glsl) on a program that reads the map."""
        radius = state.bounds.radius
        set_uniform(program, "u_eye", tuple(self.eye))
        set_uniform(program, "u_frame", tuple(np.asarray(self.frame, dtype=np.float64).T.ravel()))
        set_uniform(program, "u_orthographic", int(self.orthographic))
        set_uniform(program, "u_near", 1e-6 * radius if not self.orthographic else 0.0)
        set_uniform(program, "u_far",
                    4.0 * radius + float(np.linalg.norm(self.eye - state.bounds.centre)))
        set_uniform(program, "u_hemisphere", int(state.settings.projection != "HEMICUBE"
                                                 and not self.orthographic))


@dataclass
class Shooter:
    """One shot's patch: texels of a block, the quad they shoot from and what they take."""
    page: object
    texels: np.ndarray          # (N, 2) texels whose unshot energy this shot takes
    centre: np.ndarray
    frame: np.ndarray           # columns t, b, n
    area: float
    quad: list                  # 4 world-space corners, counter-clockwise seen from the
                                # front (about frame's n: receive_patch.frag)
    radiance: np.ndarray        # leaving its front (every shooter is one-sided)
    cell_radiance: np.ndarray   # (cells, 3): its mean over each cell of its quad
                                # (shooters.SHOOTER_CELLS)
    unshot: np.ndarray          # (N, 4) float32: what this shot takes from each texel
    incoming: np.ndarray        # (N, 4) float32: and from its incoming directions (None
                                # without lobes)
    lobe: object                # lobes.Lobe: where its glossy share goes
    cell_lobes: np.ndarray      # (cells, 4): each cell's lobe axis (xyz) and scale (w)
                                # (lobes.cell_lobes)
    surplus: np.ndarray         # (3,) W: what it shoots beyond what it took (lobes.reflect)
    albedo: np.ndarray          # its texels' mean albedo: what a thin gap's far side bounces
    surface: int                # the surface number of its strongest texel (0: it does
                                # not receive)
    emits: bool = False         # it shoots emission: its shadows are sharp
                                # (receiver_common.glsl visible_over_texel)
    extent: tuple = None        # its surface along its frame's t and b (thin_gaps.extent)
                                # when a receiver may face it across a thin gap, else None


def read_map(texture):
    """A map as float32 (height, width, components), or (height, width) for one component;
    normalized integer maps scaled to [0, 1] as the shaders read them."""
    dtype = texture.dtype.lstrip("n")
    data = np.frombuffer(texture.read(), dtype=dtype).astype(np.float32)
    if texture.dtype.startswith("n"):
        data /= np.iinfo(dtype).max
    shape = (texture.height, texture.width, texture.components)
    return data.reshape(shape).squeeze(axis=2) if texture.components == 1 else data.reshape(shape)


def decode_normals(stored):
    """Unit normals from the octahedral normal map's values in [0, 1] (texel_maps.glsl)."""
    p = (np.floor(stored[..., :2].astype(np.float64) * 65535.0 + 0.5) - OCT_STEPS) / OCT_STEPS
    z = 1.0 - np.abs(p).sum(axis=-1)
    folded = (1.0 - np.abs(p[..., ::-1])) * np.where(p >= 0.0, 1.0, -1.0)
    xy = np.where((z < 0.0)[..., None], folded, p)
    n = np.concatenate([xy, z[..., None]], axis=-1)
    return n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-30)


def decode_surface_normals(sample_normals, stored):
    """(N, 4) per texel the mean of the normals of the surface it covers (xyz, unit) and the
    mean's length, its spread (w; 1 where flat), from its ``sample_normals`` and the normal
    map's values in [0, 1] (preprocess.bent_normal_codes; texel_maps.glsl decode_bend)."""
    code = np.floor(stored[:, 3].astype(np.float64) * 65535.0 + 0.5)
    heading = (np.floor(code / (BEND_STEPS + 1)) / BEND_STEPS - 0.5) * 2.0 * math.pi
    tilt = (code % (BEND_STEPS + 1)) / BEND_STEPS * 0.5 * math.pi
    t = tangents_of(sample_normals)
    towards = (np.cos(heading)[:, None] * t
               + np.sin(heading)[:, None] * np.cross(sample_normals, t))
    mean = np.cos(tilt)[:, None] * sample_normals + np.sin(tilt)[:, None] * towards
    return np.column_stack([mean, stored[:, 2].astype(np.float64)])


def in_atlas_layout(state, page, image):
    """A packed page's (H, W, ...) array laid out as the atlas's page (zero elsewhere)."""
    if state.texel_map is None:
        return image
    here, there = page.to_atlas
    moved = np.zeros((state.atlas.height, state.atlas.width) + image.shape[2:], image.dtype)
    moved.reshape((-1,) + image.shape[2:])[there] = image.reshape((-1,) + image.shape[2:])[here]
    return moved


def blend_points(state, framebuffer, texels, values, equation):
    """Blend (N, 4) values into the texels (N, 2) of a framebuffer's first attachment by
    ``equation``, one point each (take_unshot.*)."""
    points = np.concatenate([texels, values], axis=1).astype(np.float32)
    if points.nbytes > state.points_vbo.size:
        state.points_vbo.orphan(points.nbytes)
    state.points_vbo.write(points.tobytes())
    framebuffer.use()
    with render_state(state.ctx, blend=equation):
        state.points_vao.render(moderngl.POINTS, vertices=len(points))
