"""Progressive-refinement radiosity on the GPU (Wallner 2008/2009, Section 2 of the
evaluation paper), in lightmap space, with the hemicube for visibility.

    solver = Solver(scene, Settings(texel_density=40))   # create: atlas, preprocess
    while solver.step():                                 # one shot at a time
        print(solver.progress)                           # shots, unshot fraction, seconds
    pages = solver.result()                              # current lightmaps, any time
    solver.release()                                     # every GL object, in one place

Per texel the maps hold world position and area, normal, albedo, the receiving surface's
number, the subdivision level, the accumulated irradiance E and the unshot radiance. A
lightmap texel is rho * E / pi, the
reflected diffuse radiance a Cycles DIFFUSE bake (direct + indirect + colour) writes.
"""
from dataclasses import dataclass, field
import math
import time

import moderngl
import numpy as np

from .atlas import build_atlas, charted_triangles, tight_packing
from .errors import GPUMemoryError
from .gpu import GLObjects, create_context, query_pool, using
from .scene import SpotLight, SunLight
from .settings import Settings
from .thin_gaps import (area, band_cells, chord_lengths, clipped, clipped_segment, edge_band,
                        share_under, signed_area, square, square_halves)

# Per texel (see _allocate_page): position + area, irradiance, unshot radiance + texel size
# (RGBA32F, 16 B each: sums over thousands of shots), albedo + surface number (RGBA16, 8 B:
# 16-bit fixed point holds 0.99 within 8e-6, where half floats' 0.99023 put 2.4 % more light
# in a closed room of that albedo), the octahedral normal, its spread and spread axis (RGBA16,
# 8 B) and the subdivision level (R8, 1 B). The rasterization depth (4 B) lives only until the
# irradiance is made.
BYTES_PER_TEXEL = 3 * 16 + 8 + 8 + 1
RASTER_LAYOUT = (("in_texel", 2), ("in_position", 3), ("in_normal", 3), ("in_tex_uv", 2),
                 ("in_albedo", 3), ("in_emission", 3), ("in_receive", 1))
PHASES = ("preprocess", "selection", "visibility", "subdivision", "receivers", "postprocess")
# A shooter takes the texels of its block whose unshot radiance is at least this share of the
# strongest one's; the rest wait for a later shot. Lumping a bright corner with dim texels
# would shoot the bright energy from the wrong place (across a shadow boundary, say).
SIMILAR_RADIANCE = 0.25
# Adaptive subdivision looks for shadow boundaries only in shots carrying at least this share
# of the strongest shot's power: the weak late shots add soft light, and each look costs two
# occlusion queries per receiving triangle facing the shooter.
SUBDIVISION_MIN_SHARE = 0.1
# The adaptive shooting level coarsens a shot by one level (4x the texels) for every 4x less
# power than the strongest patch shot had, by at most this many levels.
MAX_COARSER_LEVELS = 2
# One selection (an arg-max read-back, which waits for the GPU) picks up to
# Settings.shooters_per_selection patches: the strongest block of each region of the atlas
# whose power is at least this share of the strongest one's. Each shot then takes exactly the
# energy it read; what its texels receive meanwhile stays unshot for a later shot.
BATCH_MIN_SHARE = 0.25
# A plane crosses a shooting block when texels lie this share of a texel beyond it each way.
CROSSING_MARGIN = 1e-3
# A texel whose mean normal (over the surface it covers) is at least this long is flat: it
# gathers at its sample's normal. A shorter one bends within it and gathers at two normals
# (_bent_normal_codes, receiver_common.glsl), unless it is shorter than MIN_SPREAD: normals
# that cancel (a whole tube in one texel) leave no mean direction.
FLAT_SPREAD = 0.999
MIN_SPREAD = 1e-3
# A bent texel's axis and tilt (_bent_normal_codes) take 8 bits each of one 16-bit channel.
BEND_STEPS = 255
# Under this sine between a texel's sample normal and its mean normal, the sample is the mean.
BEND_DIRECTION_SINE = math.sin(math.radians(1.0))
# Edges bending less than this join triangles into one smooth surface (see smooth_surfaces).
SMOOTH_SURFACE_DEGREES = 40.0
# A gap under this share of a texel between facing surfaces is thin: receivers across it
# get all its bounces at once (_close_thin_gap).
SANDWICH_GAP = 0.1
# A surface rectangle (u min, u max, v min, v max) that holds no point.
NO_SURFACE = (1e30, -1e30, 1e30, -1e30)
# A texel across a thin gap shows the mean light over the middle of its square, this share of
# its side across: as Cycles bakes a texel (its samples jitter over half a texel; a baked step
# of emission 0.1 of a texel left of a texel's centre measured 0.70, where the whole square
# gives 0.6) (_close_thin_gap).
SHOWN_SQUARE = 0.5
# The regions: the first arg-max pyramid level with at most this many texels.
SELECTION_REGIONS = 1024
# What a shooter reads of its block: (attachment of _Page.blocks, components).
BLOCK_MAPS = ((0, 4), (1, 2), (2, 4), (3, 4))
# Surfaces are numbered 1..SURFACE_NUMBERS (the visibility map keeps 12 bits), then again.
SURFACE_NUMBERS = 4095
# The octahedral normal's steps each way of 0 in its 16-bit channels (texel_maps.glsl).
OCT_STEPS = 32767.0


@dataclass
class Progress:
    shots: int
    unshot_fraction: float   # measured before the latest shot
    seconds: float
    converged: bool          # the unshot fraction reached the threshold (or nothing is left)
    finished: bool           # converged, or stopped at max_shots
    texels: int


@dataclass
class Ledger:
    """RGB power in watts. emitted = absorbed + escaped + unshot at every step; escaped is what
    was shot and reached no receiving surface (open scenes, back faces)."""
    emitted: np.ndarray
    absorbed: np.ndarray
    escaped: np.ndarray
    unshot: np.ndarray

    def imbalance(self):
        residual = self.emitted - (self.absorbed + self.escaped + self.unshot)
        return float(np.max(np.abs(residual) / np.maximum(self.emitted, 1e-30)))


@dataclass
class _Shooter:
    page: object
    texels: np.ndarray          # (N, 2) texels whose unshot energy this shot takes
    centre: np.ndarray
    frame: np.ndarray           # columns t, b, n
    area: float
    quad: list                  # 4 world-space corners
    radiance: np.ndarray        # leaving its front (every shooter is one-sided)
    unshot: np.ndarray          # (N, 4) float32: what this shot takes from each texel
    extent: tuple               # its surface along its frame's t and b (_surface_extent)
                                # when a receiver may face it across a thin gap, else None
    albedo: np.ndarray          # its texels' mean albedo: what a thin gap's far side bounces


@dataclass
class _Texels:
    """A page's receiving texels as the CPU holds them, for the thin gaps (_close_thin_gap),
    sorted by x for the lookup around a shooter."""
    xy: np.ndarray              # (N, 2) texel coordinates
    position: np.ndarray        # (N, 3) sample points
    normal: np.ndarray          # (N, 3)
    side: np.ndarray            # (N,) the root of the area, as the shaders take it
    area: np.ndarray            # (N,) float32, as the maps hold it
    albedo: np.ndarray          # (N, 3) float32, as the maps hold it
    largest_side: float

    def near(self, centre, reach):
        """The indices of the texels whose x lies within ``reach`` and two of their sides of
        the centre's (in_near_field())."""
        radius = reach + 2.0 * self.largest_side
        first, last = np.searchsorted(self.position[:, 0], [centre[0] - radius, centre[0] + radius])
        return np.arange(first, last)


@dataclass
class _Page:
    blocks: object          # framebuffer: position, normal, unshot, material (read back
                            # per shooter)
    unshot_only: object     # framebuffer: unshot
    area_only: object       # framebuffer: position (area in .w)
    level_only: object      # framebuffer: subdivision level
    textures: dict
    pyramid: list = field(default_factory=list)   # (texture, framebuffer) from block level to 1x1
    receivers: object = None   # framebuffer: irradiance, unshot (made after rasterization)
    # Where the page's texels holding surface sit in Solver.atlas's page of the same number:
    # flat indices here and there (Solver._in_atlas_layout).
    to_atlas: tuple = None
    # Emitting texels not yet shot: flat texel indices (sorted) and their emitted power (W),
    # zeroed as they shoot (the ambient term leaves direct light out).
    emission_left: tuple = (np.zeros(0, np.int64), np.zeros((0, 3)))
    area: np.ndarray = None    # (H, W) float32: each texel's area, m^2 (it does not change)


class Solver:
    """GPU progressive radiosity for one scene. Create, step, read progress and results,
    release. Pass ``ctx`` to share an existing moderngl context; every call makes it current
    with ``with ctx:`` and restores the caller's context afterwards."""

    def __init__(self, scene, settings=None, ctx=None):
        # Back faces that receive are solved as triangles of their own, after the scene's.
        self.scene = scene.with_back_faces()
        self.settings = settings or Settings()
        self.settings.validate()
        self.timings = dict.fromkeys(PHASES, 0.0)
        self.shots = 0
        self.converged = False
        self.finished = False
        self._unshot_fraction = 1.0
        self._shot_power = np.zeros(3)
        self._owns_context = ctx is None
        self.ctx = None
        self._gl = None
        self._started = time.perf_counter()
        try:
            self.ctx = ctx if ctx is not None else create_context()
            self._gl = GLObjects(self.ctx)
            with using(self.ctx):
                self._timed("preprocess", self._preprocess)
        except BaseException:
            self.release()
            raise

    # ----------------------------------------------------------------- public API
    def step(self):
        """Shoot once: the pending lights first, then the texel patches with the most unshot
        power. Returns False, shooting nothing, once converged or out of shots."""
        if self.finished or self.ctx is None:
            return False
        if self.shots >= self.settings.max_shots:
            self.finished = True
            return False
        with using(self.ctx):
            if not self._queue and not self._select_shots():
                self.finished = True
                return False
            shot = self._queue.pop(0)
            if isinstance(shot, _Shooter):
                self._shoot_patch(shot)
            else:
                self._shoot_light(shot)
            self.shots += 1
        return True

    def run(self, callback=None):
        """Step until finished; ``callback(progress)`` after each shot may return False to stop."""
        while self.step():
            if callback is not None and callback(self.progress) is False:
                break
        return self.progress

    @property
    def progress(self):
        return Progress(self.shots, self._unshot_fraction, time.perf_counter() - self._started,
                        self.converged, self.finished, self.texel_count)

    def result(self):
        """Current lightmaps, one float32 (height, width, 4) array per atlas page, row 0 at
        v = 0 as in Blender images. RGB is reflected radiance, alpha 1 on occupied texels;
        the gutter around charts is filled with the neighbouring values (alpha 0)."""
        with using(self.ctx):
            return self._timed("postprocess", self._postprocess)

    def texel_samples(self):
        """Where each texel samples the surface, per page: a dict of (height, width, ...)
        arrays 'position' (world), 'normal', 'area' (world area the texel covers),
        'coverage' (the share of the texel square on the surface: 1 inside charts, less at
        their borders) and 'occupied' (a receiving texel). Row 0 at v = 0, as in result()."""
        with using(self.ctx):
            samples = []
            for page in self._pages:
                position = self._read(page.textures["position"])
                texel_size = self._read(page.textures["unshot"])[..., 3]
                area = position[..., 3]
                coverage = np.zeros_like(area)
                np.divide(area, texel_size ** 2, out=coverage, where=texel_size > 0)
                samples.append({name: self._in_atlas_layout(page, value) for name, value in {
                    "position": position[..., :3],
                    "normal": _decode_normals(self._read(page.textures["normal"])),
                    "area": area, "coverage": coverage,
                    "occupied": (area > 0) & (self._read(page.textures["material"])[..., 3] > 0)
                }.items()})
            return samples

    def ledger(self):
        """Energy ledger from the GPU maps (read back, summed in double precision)."""
        with using(self.ctx):
            totals = self._map_totals()
            # Thin gaps (_close_thin_gap): what their receivers' maps show is not what arrived;
            # all that arrived was absorbed in the gap.
            received = totals["received"] - self._gap_shown_received + self._gap_arrived
            absorbed = totals["absorbed"] - self._gap_shown_absorbed + self._gap_arrived
            return Ledger(self._emitted.copy(), absorbed, self._shot_power - received,
                          totals["unshot"])

    def ambient_radiance(self):
        """The unshot light that has bounced at least once, as uniform radiance (Cohen et al.
        1988): the share c of it that lands (c = received / shot so far: 1 in a closed
        room), spread over the area, times 1 / (1 - c * mean albedo), the sum of its further
        bounces. Emission not yet shot (lights, emitting texels) is left out: direct light
        is far from even, and it shoots first anyway. result() adds albedo times this when
        Settings.ambient is on."""
        with using(self.ctx):
            return self._ambient([self._read(page.textures["irradiance"])
                                  for page in self._pages])

    def _ambient(self, irradiance):
        """ambient_radiance() from the pages' irradiance maps (result() reads them anyway)
        and their unshot maps; the area and albedo sums are the setup's (_measure_emission)."""
        received, unshot = self._gap_arrived - self._gap_shown_received, np.zeros(3)
        for page, page_irradiance in zip(self._pages, irradiance):
            # Whole RGBA rows times the areas: one product each (an estimate needs no
            # double-precision sums; the ledger's are).
            area = page.area.reshape(-1)
            received = received + (page_irradiance.reshape(-1, 4).T @ area)[:3]
            unshot = unshot + math.pi * (self._read(page.textures["unshot"]).reshape(-1, 4).T
                                         @ area)[:3]
            unshot = unshot - page.emission_left[1].sum(axis=0)   # direct light, unshot
        bounced = np.maximum(unshot, 0.0)
        shot = float(np.mean(self._shot_power)) - self._sunlight_missed
        lands = min(float(np.mean(received)) / shot, 1.0) if shot > 0 else 1.0
        area = max(self._surface_area, 1e-30)
        mean_albedo = np.minimum(self._albedo_area / area, 0.999)
        return lands * bounced / (math.pi * area) / (1.0 - lands * mean_albedo)

    def _map_totals(self):
        """Sums over every texel of the maps, in double precision: the irradiance received and
        absorbed (W) and the unshot power (W, with pending lights)."""
        totals = {key: np.zeros(3) for key in ("absorbed", "received", "unshot")}
        for page in self._pages:
            maps = {name: self._read(page.textures[name])
                    for name in ("material", "irradiance", "unshot")}
            area = page.area[..., None].astype(np.float64)
            albedo = maps["material"][..., :3] * (maps["material"][..., 3:4] > 0)
            irradiance = maps["irradiance"][..., :3] * area
            totals["received"] += irradiance.reshape(-1, 3).sum(axis=0)
            totals["absorbed"] += ((1.0 - albedo) * irradiance).reshape(-1, 3).sum(axis=0)
            totals["unshot"] += math.pi * (maps["unshot"][..., :3] * area).reshape(-1, 3).sum(axis=0)
        queued = [shot for shot in self._queue if not isinstance(shot, _Shooter)]
        for light in self._pending + queued:
            totals["unshot"] += self._light_power(light)
        return totals

    def release(self):
        """Release every GL object (and the context, if the solver made it). Idempotent."""
        if self._gl is not None:
            with using(self.ctx):
                self._gl.release()
            self._gl = None
        if self.ctx is not None and self._owns_context:
            self.ctx.release()
        self.ctx = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()

    @property
    def gl_object_count(self):
        return 0 if self._gl is None else len(self._gl)

    @property
    def texel_count(self):
        return self._texel_count

    @property
    def gpu_memory_bytes(self):
        return self._memory_bytes

    @property
    def page_size(self):
        """(width, height) of the lightmap pages result() returns (self.atlas's)."""
        return self.atlas.width, self.atlas.height

    @property
    def gpu_page_size(self):
        """(width, height) of the pages the GPU works on: the charts packed tight."""
        return self._packed.width, self._packed.height

    # ----------------------------------------------------------------- preprocess
    def _preprocess(self):
        settings = self.settings
        scene = self.scene
        lo, hi = scene.bounds()
        self._centre = 0.5 * (lo + hi)
        self._radius = 0.5 * float(np.linalg.norm(hi - lo)) * 1.01 + 1e-6
        self._epsilon = 1e-5 * self._radius
        # Hemisphere maps are twice the hemicube's side: the same texels per radian at the zenith.
        self._map_size = settings.hemicube_resolution * (1 if settings.projection == "HEMICUBE" else 2)
        surfaces = smooth_surfaces(scene)
        # Emitting surfaces first, so that they win ties in the visibility map (and are known
        # there by their numbers): a lamp drawn in the ceiling's plane covers the ceiling.
        emits = np.zeros(surfaces.max() + 1, dtype=bool)
        emits[surfaces[scene.emission.max(axis=1) > 0.0]] = True
        renumber = np.empty_like(emits, dtype=np.int64)
        renumber[np.argsort(~emits, kind="stable")] = np.arange(len(emits))
        self._emitting_surfaces = min(int(emits.sum()), SURFACE_NUMBERS)
        # 0 marks texels that do not receive.
        self._surfaces = renumber[surfaces] % SURFACE_NUMBERS + 1
        if scene.back_of is not None:   # a back face is its front's surface: one sheet
            copies = scene.back_of >= 0
            self._surfaces[copies] = self._surfaces[scene.back_of[copies]]

        self._check_surface_fits()
        started = time.perf_counter()
        self.atlas = build_atlas(scene, settings.texel_density, settings.max_atlas_size,
                                 settings.padding, align=1 << settings.shoot_level)
        # The GPU works on the charts packed tight; results go back to self.atlas's layout.
        self._packed, self._texel_map = tight_packing(self.atlas, 1 << settings.shoot_level)
        self.atlas_seconds = time.perf_counter() - started   # of preprocess: xatlas, on the CPU
        self._check_memory()
        gl = self._gl
        self._programs = {
            "attributes": gl.program("raster.vert", "raster_attributes.frag", "raster.geom"),
            "area": gl.program("raster.vert", "raster_area.frag", "raster.geom"),
            "moments": gl.program("raster.vert", "normal_moments.frag", "raster.geom"),
            "block": gl.program("fullscreen.vert", "block_power.frag"),
            "argmax": gl.program("fullscreen.vert", "argmax.frag"),
            "visibility": gl.program("visibility.vert", "visibility.frag", "visibility.geom"),
            "hemisphere": gl.program("visibility_hemisphere.vert", "visibility_hemisphere.frag",
                                     "visibility_hemisphere.geom"),
            "hemisphere_tessellated": gl.program(
                "visibility_hemisphere.vert", "visibility_hemisphere.frag",
                "visibility_hemisphere_tessellated.geom"),
            "nonlinear": gl.program("visibility.vert", "visibility_nonlinear.frag",
                                    "visibility_nonlinear.geom"),
            "patch": gl.program("fullscreen.vert", "receive_patch.frag"),
            "light": gl.program("fullscreen.vert", "receive_light.frag"),
            "take": gl.program("take_unshot.vert", "take_unshot.frag"),
        }
        if settings.subdivision != "NONE":
            self._programs["count"] = gl.program("raster.vert", "shadow_count.frag", "raster.geom")
            self._programs["level"] = gl.program("raster.vert", "set_level.frag", "raster.geom")
        self._fullscreen = {name: gl.vertex_array(self._programs[name], [])
                            for name in ("block", "argmax", "patch", "light")}
        self._set_constant_uniforms()
        self._albedo_textures = []
        for image in scene.albedo_textures:
            image = np.asarray(image, dtype=np.float32)
            rgba = np.ones(image.shape[:2] + (4,), np.float32)
            rgba[..., :image.shape[2]] = image
            texture = gl.texture(image.shape[1::-1], 4, data=rgba.tobytes())
            texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self._albedo_textures.append(texture)

        size = (self._packed.width, self._packed.height)
        self._pages = [self._allocate_page(size) for _ in range(self._packed.page_count)]
        self._rasterize()

        resolution, layers = self._map_size, 6 if settings.projection == "HEMICUBE" else 2
        self._visibility = gl.texture_array((resolution, resolution, layers), 2)
        self._visibility_fbo = gl.framebuffer([self._visibility])
        # Only occluders go into the visibility buffer; at least one triangle keeps it valid.
        occluders = scene.triangles[scene.occlude] if scene.occlude.any() else scene.triangles[:0]
        positions = scene.vertices[occluders].astype("f4")
        surfaces = self._surfaces[scene.occlude]
        if not len(positions):
            positions = np.full((1, 3, 3), 1e30, dtype="f4")
            surfaces = np.zeros(1)
        self._scene_vbo = gl.buffer(positions.tobytes())
        surface_vbo = gl.buffer(np.repeat(surfaces, 3).astype("f4").tobytes())
        scene_content = [(self._scene_vbo, "3f", "in_position"), (surface_vbo, "1f", "in_surface")]
        self._visibility_vaos = {name: gl.vertex_array(self._programs[name], scene_content)
                                 for name in ("visibility", "hemisphere", "nonlinear")}
        # Occluders' planes, to keep a shooter on one side of what crosses it; receivers', to
        # find the thin gaps next to a shooter.
        self._occluders = _TrianglePlanes(positions.astype(np.float64))
        self._receivers = _TrianglePlanes(
            scene.vertices[scene.triangles[scene.receive]].astype(np.float64))
        self._crossing_planes = {}   # per shooting block region
        self._thin_gaps = {}         # per shooting region: whether a receiver faces it closely
        self._region_charts = {}     # per shooting block region: _region_charts
        initial = settings.subdivision_level if settings.subdivision == "REGULAR" else 0
        self._caster_levels = np.full(len(positions), initial, dtype=np.int32)
        self._caster_vbo = gl.buffer(np.repeat(self._caster_levels, 3).astype("f4").tobytes())
        self._visibility_vaos["hemisphere_tessellated"] = gl.vertex_array(
            self._programs["hemisphere_tessellated"],
            scene_content + [(self._caster_vbo, "1f", "in_caster_level")])
        self._triangle_vertices = positions.shape[0] * 3
        block = 1 << (settings.shoot_level + (MAX_COARSER_LEVELS if settings.adaptive_shoot_level
                                              else 0))
        # One point per texel whose maps a shot changes in place (_blend_points): what the
        # shot took, a thin gap's light. Grows with the largest such set.
        self._points_vbo = gl.buffer(reserve=block * block * 24)
        # The BLOCK_MAPS of every block of a selection.
        self._staging = gl.buffer(reserve=settings.shooters_per_selection * block * block * 4
                                  * sum(components for _, components in BLOCK_MAPS))
        self._surface_corners = {}  # surface number -> its triangles' corners (_corners_of)
        self._strongest_patch = 0.0
        self._strongest_shot = 0.0
        self._queue = []
        self._points_vao = gl.vertex_array(self._programs["take"],
                                           [(self._points_vbo, "2f 4f", "in_texel", "in_taken")])
        self._receiving_texels = None   # per page, _Texels, read at the first thin gap
        self._page_triangles = None     # per page, its triangles' texel and world corners,
                                        # open edges and texel bounds (_lit_by)
        self._lit_polygons = {}         # (page, x0, y0, x1, y1) -> what those texels cover
        # Thin gaps' receivers (_close_thin_gap), W: the irradiance they show times their area,
        # its part they absorb (as the maps would count it), and what really arrived.
        self._gap_shown_received = np.zeros(3)
        self._gap_shown_absorbed = np.zeros(3)
        self._gap_arrived = np.zeros(3)

        self._measure_emission()
        lights = list(scene.lights) + sky_suns(scene.sky, settings.sky_directions)
        self._pending = [light for light in lights if np.mean(self._light_power(light)) > 0]
        self._emitted = self._emitted_maps + sum((self._light_power(l) for l in self._pending),
                                                 np.zeros(3))
        self._emitted_scalar = float(np.mean(self._emitted))
        # A sun shoots over the scene's bounding square: what misses the scene (three times
        # what lands, on the temple's ground) is emitted for the ledger but not left for the
        # threshold to wait on.
        self._sunlight_missed = 0.0

    def _set_constant_uniforms(self):
        """Uniforms that stay the same for the whole bake (texture units among them)."""
        size = (float(self._packed.width), float(self._packed.height))
        receivers = {"u_resolution": float(self._map_size),
                     "u_epsilon": self._epsilon, "u_ortho_half": self._radius,
                     "u_neighbour_visibility": int(self.settings.neighbour_visibility),
                     "u_emitting_surfaces": self._emitting_surfaces,
                     "u_visibility": 0, "u_position": 1, "u_normal": 2, "u_material": 3,
                     "u_level": 4}
        constants = {
            "attributes": {"u_atlas_size": size, "u_albedo_texture": 0},
            "area": {"u_atlas_size": size},
            "moments": {"u_atlas_size": size, "u_normal": 0},
            "block": {"u_block": 1 << self.settings.shoot_level,
                      "u_position": 0, "u_unshot": 1},
            "argmax": {"u_source": 0},
            "visibility": {"u_ortho_half": self._radius},
            "nonlinear": {"u_resolution": float(self._map_size)},
            "hemisphere": {"u_resolution": float(self._map_size)},
            "hemisphere_tessellated": {"u_resolution": float(self._map_size)},
            "patch": {**receivers, "u_sandwich_gap": SANDWICH_GAP},
            "light": receivers,
            "take": {"u_atlas_size": size},
            "count": {**receivers, "u_atlas_size": size},
            "level": {**receivers, "u_atlas_size": size},
        }
        for name, uniforms in constants.items():
            if name not in self._programs:
                continue
            for uniform, value in uniforms.items():
                _set(self._programs[name], uniform, value)

    def _memory_needed(self, atlas):
        texels = atlas.width * atlas.height * atlas.page_count
        block = 1 << self.settings.shoot_level
        pyramid = texels / (block * block) * 16 * 4 / 3
        visibility = self._map_size ** 2 * 6 * 4
        return int(texels * BYTES_PER_TEXEL + pyramid + visibility)

    def _fits(self, atlas):
        max_size = self.ctx.info["GL_MAX_TEXTURE_SIZE"]
        return (self._memory_needed(atlas) <= self.settings.memory_limit
                and max(atlas.width, atlas.height) <= max_size)

    def _check_surface_fits(self):
        """Refuse, before xatlas charts it, a density whose surface alone overflows the
        memory: at 10^4 texels per metre xatlas takes 100 s on a 4 m room, at 10^6 hours."""
        density = self.settings.texel_density
        if not np.isfinite(density) or density <= 0.0:
            return  # build_atlas names the bad value
        scene = self.scene
        charted = charted_triangles(scene)
        scales = np.asarray(scene.object_texel_scale)[scene.object_index[charted]]
        surface = float(np.sum(scene.triangle_area[charted] * scales ** 2))  # m^2 at density 1
        needed = surface * density ** 2 * BYTES_PER_TEXEL
        limit = int(self.settings.memory_limit)
        if needed <= limit:
            return
        # Charts are padded and packed with gaps: start from half the memory for the surface.
        fits = self._density_that_fits(math.sqrt(0.5 * limit / (surface * BYTES_PER_TEXEL)))
        raise GPUMemoryError(
            f"the lightmaps need at least {needed / 2**20:,.0f} MiB of GPU memory at "
            f"{density:.4g} texels per metre but {limit / 2**20:.1f} MiB are allowed: "
            f"{_lower_to(fits)}", int(needed), limit, fits)

    def _check_memory(self):
        atlas = self._packed
        self._memory_bytes = self._memory_needed(atlas)
        if self._fits(atlas):
            return
        # Texels scale with the square of the density; padding does not, so search down.
        limit = int(self.settings.memory_limit)
        fits = self._density_that_fits(atlas.density * math.sqrt(limit / self._memory_bytes))
        raise GPUMemoryError(
            f"the lightmaps need {self._memory_bytes / 2**20:.1f} MiB of GPU memory "
            f"({atlas.width}x{atlas.height} texels on {atlas.page_count} page(s)) but "
            f"{limit / 2**20:.1f} MiB are allowed: {_lower_to(fits, atlas.density)}",
            self._memory_bytes, limit, fits)

    def _density_that_fits(self, density):
        """The first density from ``density`` down in steps of 15 % whose atlas fits, or
        None when even 1/130 of it does not."""
        for _ in range(30):
            align = 1 << self.settings.shoot_level
            if self._fits(tight_packing(build_atlas(self.scene, density,
                                                    self.settings.max_atlas_size,
                                                    self.settings.padding, align=align),
                                        align)[0]):
                return density
            density *= 0.85
        return None

    def _allocate_page(self, size):
        """A page's maps but the irradiance, which _rasterize makes once its depth is gone."""
        gl = self._gl
        textures = {
            "position": gl.texture(size, 4),            # xyz, area
            "normal": gl.texture(size, 4, "nu2"),       # octahedral (texel_maps.glsl), spread
            "material": gl.texture(size, 4, "nu2"),     # albedo, surface number
            "unshot": gl.texture(size, 4),              # radiance, texel size
            "level": gl.texture(size, 1, "nu1"),        # subdivision level
        }
        page = _Page(
            blocks=gl.framebuffer([textures[n] for n in ("position", "normal", "unshot",
                                                        "material")]),
            unshot_only=gl.framebuffer([textures["unshot"]]),
            area_only=gl.framebuffer([textures["position"]]),
            level_only=gl.framebuffer([textures["level"]]),
            textures=textures)
        block = 1 << self.settings.shoot_level
        level = (-(-size[0] // block), -(-size[1] // block))
        # The arg-max pyramid stops at the grid of regions that selection reads back.
        while True:
            texture = gl.texture(level, 4)
            page.pyramid.append((texture, gl.framebuffer([texture])))
            if level[0] * level[1] <= SELECTION_REGIONS:
                break
            level = (-(-level[0] // 2), -(-level[1] // 2))
        return page

    def _rasterize(self):
        scene, atlas = self.scene, self._packed
        tris = atlas.triangles
        corners = scene.triangles[tris]
        positions = scene.vertices[corners]
        if scene.normals is not None:
            normals = scene.normals[corners]
        else:
            face = np.cross(positions[:, 1] - positions[:, 0], positions[:, 2] - positions[:, 0])
            normals = np.repeat(face[:, None, :], 3, axis=1)
        tex_uv = (scene.albedo_uv[tris] if scene.albedo_uv is not None
                  else np.zeros((len(tris), 3, 2)))
        texture_index = scene.albedo_texture_index[tris]
        per_corner = lambda values: np.repeat(values[:, None, :], 3, axis=1)
        vertex_data = np.concatenate([
            atlas.texels, positions, normals, tex_uv, per_corner(scene.albedo[tris]),
            per_corner(scene.emission[tris]),
            per_corner((scene.receive * self._surfaces)[tris, None].astype(float)),
        ], axis=2).astype("f4")
        # Draw in runs of (page, albedo texture).
        order = np.lexsort((texture_index, atlas.page))
        vertex_data = vertex_data[order]
        keys = np.stack([atlas.page[order], texture_index[order]], axis=1)
        starts = np.nonzero(np.r_[True, (keys[1:] != keys[:-1]).any(axis=1)])[0]
        ends = np.r_[starts[1:], len(keys)]

        gl = self._gl
        vbo = gl.buffer(vertex_data.tobytes())
        vaos = {name: gl.vertex_array(self._programs[name],
                                      [_buffer_content(self._programs[name], vbo, RASTER_LAYOUT)])
                for name in ("attributes", "area", "moments")}
        ctx = self.ctx
        self._prepare_subdivision(vbo, tris[order], atlas.page[order])

        # The attributes, and the emission as the first unshot radiance, with a depth map the
        # pages share in turn (pages are drawn in order).
        depth = gl.depth_texture((atlas.width, atlas.height))
        rasters = [gl.framebuffer([page.textures[name] for name in
                                   ("position", "normal", "material", "unshot")], depth)
                   for page in self._pages]
        for page in self._pages:
            page.level_only.clear(0.0, 0.0, 0.0, 0.0)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        program = self._programs["attributes"]
        rasters[0].clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        for start, end in zip(starts, ends):   # runs are sorted by page
            page_index, texture = keys[start]
            if start and keys[start - 1][0] != page_index:   # the next page: the depth anew
                rasters[page_index].clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
            rasters[page_index].use()
            _set(program, "u_use_texture", int(texture >= 0))
            if texture >= 0:
                self._albedo_textures[texture].use(location=0)
            vaos["attributes"].render(moderngl.TRIANGLES, vertices=3 * (end - start),
                                      first=3 * start)
        ctx.disable(moderngl.DEPTH_TEST)
        # moderngl binds the last used framebuffer again after making one: not a released one.
        self._pages[0].area_only.use()
        gl.release_now(*rasters, depth)
        # The irradiance takes the depth's memory: the peak stays at BYTES_PER_TEXEL.
        for page in self._pages:
            irradiance = page.textures["irradiance"] = gl.texture(
                (atlas.width, atlas.height), 4)
            page.receivers = gl.framebuffer([irradiance, page.textures["unshot"]])
        self._measure_surface(vaos, keys[starts, 0], starts, ends)
        for page in self._pages:
            page.receivers.color_mask = [(True,) * 4, (False,) * 4]   # the unshot holds emission
            page.receivers.clear(0.0, 0.0, 0.0, 0.0)
            page.receivers.color_mask = [(True,) * 4, (True,) * 4]

        if self.settings.subdivision == "REGULAR":
            self._raise_levels(np.nonzero(self._slot_receives)[0], self.settings.subdivision_level)

    def _measure_surface(self, vaos, run_pages, starts, ends):
        """Each texel's world area (the position map's .w) and, where its surface bends within
        it, the spread of its normals (_bent_normal_codes): sums over the texel's triangles by
        additive blending, with the irradiance map, not yet in use, holding them in turn."""
        scope = self._gl.temporary_framebuffer
        for page_index, page in enumerate(self._pages):
            runs = list(zip(starts[run_pages == page_index], ends[run_pages == page_index]))
            irradiance, after = page.textures["irradiance"], page.area_only
            with scope([page.textures["position"], irradiance], then=after,
                       color_mask=[(False, False, False, True), (True,) * 4]) as sums:
                sums.clear(0.0, 0.0, 0.0, 0.0)   # the mask keeps the position's xyz
                self._add_up(vaos["area"], runs)
            normal_sum = self._read(irradiance).astype(np.float64)
            covered = normal_sum[..., 3]
            mean_length = np.linalg.norm(normal_sum[..., :3], axis=-1)
            spread = np.divide(mean_length, covered, out=np.ones_like(covered),
                               where=covered > 0.0)
            bent = (spread < FLAT_SPREAD) & (spread > MIN_SPREAD)
            if not bent.any():
                continue
            normal = page.textures["normal"]
            normal.use(location=0)
            with scope([irradiance], then=after) as moments:
                moments.clear(0.0, 0.0, 0.0, 0.0)
                self._add_up(vaos["moments"], runs)
            stored = np.frombuffer(normal.read(), dtype=np.uint16).reshape(
                normal.height, normal.width, 4).copy()
            stored[bent, 2:] = _bent_normal_codes(
                normal_sum[bent], self._read(irradiance)[bent].astype(np.float64),
                _decode_normals(stored[bent] / 65535.0))
            normal.write(stored.tobytes())

    def _add_up(self, vao, runs):
        """Draw the triangle runs with additive blending into the bound framebuffer."""
        ctx = self.ctx
        ctx.enable(moderngl.BLEND)
        ctx.blend_equation = moderngl.FUNC_ADD
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        for start, end in runs:
            vao.render(moderngl.TRIANGLES, vertices=3 * (end - start), first=3 * start)
        ctx.disable(moderngl.BLEND)

    # ----------------------------------------------------------------- subdivision
    def _prepare_subdivision(self, vbo, slot_triangles, slot_pages):
        """Per triangle of the lightmap vertex buffer (its 'slot'): page, geometry and
        subdivision level, for the occlusion queries and level updates."""
        scene = self.scene
        self._slot_pages = slot_pages
        self._slot_receives = scene.receive[slot_triangles]
        self._slot_levels = np.zeros(len(slot_triangles), dtype=np.int32)
        if self.settings.subdivision == "NONE":
            return
        corners = scene.vertices[scene.triangles[slot_triangles]]
        self._slot_corners = corners
        self._slot_centres = corners.mean(axis=1)
        normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        self._slot_normals = normals / np.maximum(np.linalg.norm(normals, axis=1), 1e-30)[:, None]
        self._level_vaos = {
            name: self._gl.vertex_array(self._programs[name],
                                        [_buffer_content(self._programs[name], vbo, RASTER_LAYOUT)])
            for name in ("count", "level")}

    def _raise_levels(self, slots, level, boundary_only=False):
        """Subdivide the triangles in ``slots`` to ``level``: their texels (only those on the
        current shot's shadow boundary with ``boundary_only``) gather light at 4^level points
        from now on."""
        if len(slots) == 0:
            return
        self._slot_levels[slots] = np.maximum(self._slot_levels[slots], level)
        program = self._programs["level"]
        _set(program, "u_level", float(level))
        _set(program, "u_boundary_only", int(boundary_only))
        if boundary_only:
            self._view_uniforms(program, *self._view)
            self._visibility.use(location=0)
        ctx = self.ctx
        ctx.enable(moderngl.BLEND)
        ctx.blend_equation = moderngl.MAX
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        vao = self._level_vaos["level"]
        for page_slots in self._per_page(slots, "level_only", (True, True, True, True)):
            for first, count in _runs(page_slots):
                vao.render(moderngl.TRIANGLES, vertices=3 * count, first=3 * first)
        ctx.blend_equation = moderngl.FUNC_ADD
        ctx.disable(moderngl.BLEND)

    def _subdivide_shadowed(self, clip_below):
        """Adaptive subdivision after the visibility map is drawn: occlusion queries count the
        lit and shadowed texels of each receiving triangle facing the shooter; a triangle whose
        shadowed share lies between the thresholds is refined along the shadow boundary."""
        settings = self.settings
        eye, frame, orthographic = self._view
        candidates = self._slot_receives.copy()
        if orthographic:
            candidates &= self._slot_normals @ -frame[:, 2] > 0.0
        else:
            candidates &= ((eye - self._slot_centres) * self._slot_normals).sum(axis=1) > 0.0
            if clip_below:
                heights = (self._slot_corners - eye) @ frame[:, 2]
                candidates &= heights.max(axis=1) > 0.0
        slots = np.nonzero(candidates)[0]
        if len(slots) == 0:
            return
        program = self._programs["count"]
        self._view_uniforms(program, eye, frame, orthographic)
        _set(program, "u_clip_below", int(clip_below))
        self._visibility.use(location=0)
        queries = query_pool(self.ctx)
        batch = len(queries) // 2
        counts = np.concatenate([self._count_shadowed(slots[start:start + batch], queries)
                                 for start in range(0, len(slots), batch)])
        looked = counts.sum(axis=1)
        share = np.divide(counts[:, 1], looked, out=np.zeros(len(slots)), where=looked > 0)
        shadowed = ((looked > 0) & (share >= settings.subdivision_shadow_min)
                    & (share <= settings.subdivision_shadow_max))
        # Each time a triangle shows a shadow boundary it goes one level finer (up to the
        # maximum), and the texels on this shot's boundary take that level.
        next_level = np.minimum(self._slot_levels[slots] + 1, settings.subdivision_level)
        for level in range(1, settings.subdivision_level + 1):
            self._raise_levels(slots[shadowed & (next_level == level)], level,
                               boundary_only=True)
        if settings.projection == "HEMISPHERE" and shadowed.any():
            self._subdivide_casters(slots[shadowed])

    def _subdivide_casters(self, receiver_slots):
        """Raise the casters of the subdivided receivers' shadows to the receivers' level: the
        occluders whose bounding spheres meet the cone from the eye to a receiver's bounding
        sphere, in front of it."""
        eye = self._view[0]
        if self._view[2]:  # the sun: a cylinder along its direction, from far behind
            eye = self._view[0] - self._view[1][:, 2] * 4.0 * self._radius
        corners = self._slot_corners[receiver_slots]
        centres = corners.mean(axis=1)
        radii = np.linalg.norm(corners - centres[:, None], axis=2).max(axis=1)
        levels = self._slot_levels[receiver_slots]
        axis = centres - eye
        length = np.linalg.norm(axis, axis=1)
        axis /= np.maximum(length, 1e-30)[:, None]
        to_caster = self._occluders.centres[None, :, :] - eye                    # (1, O, 3)
        along = (to_caster * axis[:, None, :]).sum(axis=2)                       # (R, O)
        across = np.linalg.norm(to_caster - along[..., None] * axis[:, None, :], axis=2)
        cone = radii[:, None] * np.clip(along, 0.0, None) / np.maximum(length, 1e-30)[:, None]
        radii = self._occluders.radii
        meets = ((along + radii > 0.0) & (along - radii < length[:, None])
                 & (across <= cone + radii))
        wanted = np.max(np.where(meets, levels[:, None], 0), axis=0)
        raised = wanted > self._caster_levels
        if raised.any():
            self._caster_levels = np.maximum(self._caster_levels, wanted)
            self._caster_vbo.write(np.repeat(self._caster_levels, 3).astype("f4").tobytes())

    def _per_page(self, slots, framebuffer, color_mask):
        """Yield the part of ``slots`` on each page, with that page's ``framebuffer`` bound
        under ``color_mask`` and its position, normal and material maps on units 1 to 3."""
        for page_index in np.unique(self._slot_pages[slots]):
            page = self._pages[page_index]
            target = getattr(page, framebuffer)
            target.color_mask = color_mask  # applied by use()
            target.use()
            page.textures["position"].use(location=1)
            page.textures["normal"].use(location=2)
            page.textures["material"].use(location=3)
            yield slots[self._slot_pages[slots] == page_index]
            target.color_mask = (True, True, True, True)

    def _count_shadowed(self, slots, queries):
        """(lit, shadowed) texel counts of each triangle in ``slots``, by occlusion queries."""
        program = self._programs["count"]
        vao = self._level_vaos["count"]
        index = 0
        # Only the query counts matter: nothing is written.
        for page_slots in self._per_page(slots, "unshot_only", (False, False, False, False)):
            for slot in page_slots:
                for hidden in (0, 1):
                    _set(program, "u_count_hidden", hidden)
                    with queries[index + hidden]:
                        vao.render(moderngl.TRIANGLES, vertices=3, first=3 * int(slot))
                index += 2
        return np.array([query.samples for query in queries[:index]],
                        dtype=np.float64).reshape(-1, 2)

    def subdivided_texel_share(self):
        """Share of the receiving texels that are subdivided (gather at more than one point)."""
        with using(self.ctx):
            subdivided = occupied = 0
            for page in self._pages:
                receives = (self._read(page.textures["position"])[..., 3] > 0) & (
                    self._read(page.textures["material"])[..., 3] > 0)
                levels = self._read(page.textures["level"])
                subdivided += int(np.count_nonzero(receives & (levels > 0)))
                occupied += int(np.count_nonzero(receives))
            return subdivided / max(occupied, 1)

    def _measure_emission(self):
        """Emitted power as the texels hold it (the unshot maps start as the emission),
        summed in double precision; the receiving texels, and the blocks at the shooting
        level that hold texels (a mean block's share of the power, for _block_region)."""
        self._emitted_maps = np.zeros(3)
        self._surface_area, self._albedo_area = 0.0, np.zeros(3)   # m^2: all texels, receiving
        self._texel_count = 0
        self._shooting_blocks = 0   # blocks at the shooting level holding texels
        block = 1 << self.settings.shoot_level
        for page_index, page in enumerate(self._pages):
            area = self._read(page.textures["position"])[..., 3:4]
            height, width = area.shape[:2]
            padded = np.zeros((-(-height // block) * block, -(-width // block) * block), bool)
            padded[:height, :width] = area[..., 0] > 0
            self._shooting_blocks += int(np.count_nonzero(padded.reshape(
                padded.shape[0] // block, block, padded.shape[1] // block, block).any(axis=(1, 3))))
            emission = self._read(page.textures["unshot"])[..., :3]
            material = self._read(page.textures["material"])
            receives = material[..., 3]
            page.area = np.ascontiguousarray(area[..., 0])
            self._surface_area += float(area.sum(dtype=np.float64))
            self._albedo_area = self._albedo_area + (
                material[..., :3] * (receives[..., None] > 0) * area).reshape(-1, 3).sum(
                axis=0, dtype=np.float64)
            page.to_atlas = self._atlas_texels(page_index, area[..., 0] > 0)
            power = math.pi * (emission * area).reshape(-1, 3).astype(np.float64)
            self._emitted_maps += power.sum(axis=0)
            emitting = np.flatnonzero(power.max(axis=1) > 0)
            page.emission_left = (emitting, power[emitting])
            self._texel_count += int(np.count_nonzero((area[..., 0] > 0) & (receives > 0)))

    def _atlas_texels(self, page_index, holds_surface):
        """(flat indices on the packed page, flat indices on self.atlas's page) of the texels
        ``holds_surface`` (H, W) marks: each moves back by its chart's offset."""
        here = np.flatnonzero(holds_surface)
        texel_map = self._texel_map
        if texel_map is None:
            return here, here
        width = self._packed.width
        chart_at = np.full(holds_surface.shape, -1, dtype=np.int64)
        for chart in np.nonzero(texel_map.chart_page == page_index)[0]:
            x0, y0, x1, y1 = texel_map.boxes[chart]
            chart_at[y0:y1, x0:x1] = chart
        here = here[chart_at.ravel()[here] >= 0]   # every texel lies in its chart's box
        offsets = texel_map.offsets[chart_at.ravel()[here]]
        x, y = here % width - offsets[:, 0], here // width - offsets[:, 1]
        return here, y * self.atlas.width + x

    def _in_atlas_layout(self, page, image):
        """A packed page's (H, W, ...) array laid out as self.atlas's page (zero elsewhere)."""
        if self._texel_map is None:
            return image
        here, there = page.to_atlas
        moved = np.zeros((self.atlas.height, self.atlas.width) + image.shape[2:], image.dtype)
        moved.reshape((-1,) + image.shape[2:])[there] = image.reshape((-1,) + image.shape[2:])[here]
        return moved

    # ----------------------------------------------------------------- selection
    def _select_shots(self):
        """Measure the unshot power and queue the next shots: up to shooters_per_selection
        pending lights, or as many patches. False once converged."""
        candidates, total = self._timed("selection", self._select)
        pending = sum(float(np.mean(self._light_power(light))) for light in self._pending)
        self._unshot_fraction = (total + pending) / max(
            self._emitted_scalar - self._sunlight_missed, 1e-30)
        self.converged = (self._unshot_fraction <= self.settings.threshold
                          or (not self._pending and not candidates))
        if self.converged:
            return False
        count = min(self.settings.shooters_per_selection,
                    self.settings.max_shots - self.shots)
        if self._pending:
            self._queue, self._pending = self._pending[:count], self._pending[count:]
            return True
        self._queue = self._timed("selection", self._gather_shooters, candidates, count)
        # The GPU's float sums saw power the texels do not hold.
        self.converged = not self._queue
        return not self.converged

    def _select(self):
        """Masked arg-max over the shooting level on the GPU, down to a grid of regions that
        is read back. Returns the total unshot power and [(power, page, block)] of the
        strongest blocks of their regions, strongest first: those with at least
        BATCH_MIN_SHARE of the strongest power, at most twice the batch (blocks inside
        others are dropped later)."""
        grids = []
        for index, page in enumerate(self._pages):
            texture, fbo = page.pyramid[0]
            fbo.use()
            page.textures["position"].use(location=0)
            page.textures["unshot"].use(location=1)
            self._fullscreen["block"].render(moderngl.TRIANGLES, vertices=3)
            for (source, _), (_, target) in zip(page.pyramid, page.pyramid[1:]):
                target.use()
                source.use(location=0)
                self._fullscreen["argmax"].render(moderngl.TRIANGLES, vertices=3)
            grid = np.frombuffer(page.pyramid[-1][0].read(), dtype="f4").reshape(-1, 4)
            grids.append(np.concatenate([grid, np.full((len(grid), 1), index, "f4")], axis=1))
        grid = np.concatenate(grids).astype(np.float64)
        total = float(grid[:, 3].sum())
        strongest = grid[:, 0].max(initial=0.0)
        if strongest <= 0.0:
            return [], total
        chosen = np.nonzero(grid[:, 0] >= BATCH_MIN_SHARE * strongest)[0]
        chosen = chosen[np.argsort(-grid[chosen, 0], kind="stable")]
        return [(grid[i, 0], int(grid[i, 4]), (int(grid[i, 1]), int(grid[i, 2])))
                for i in chosen[:2 * self.settings.shooters_per_selection]], total

    # ----------------------------------------------------------------- shooting
    def _coarser_levels(self, power):
        """Adaptive shooting level: how many levels coarser than shoot_level this shot is,
        from its block's power against the strongest patch shot so far."""
        if not self.settings.adaptive_shoot_level:
            return 0
        self._strongest_patch = max(self._strongest_patch, power)
        ratio = self._strongest_patch / max(power, 1e-30)
        return int(min(MAX_COARSER_LEVELS, max(0.0, math.log(ratio, 4.0))))

    def _gather_shooters(self, candidates, count):
        """Shooters of up to ``count`` candidate blocks (or of their finer parts), strongest
        first, skipping a block inside one already taken (adaptive levels). Their texels are
        read back before any of them shoots, all in one wait for the GPU."""
        regions, finer = [], []
        for power, page_index, block in candidates:
            region, levels = self._block_region(page_index, block, power)
            if not any(_overlap(region, other) for other in regions):
                regions.append(region)
                finer.append(levels)
            if len(regions) == count:
                break
        shooters = [self._make_shooter(part, part_maps, self._charts_of(region, maps, rows))
                    for region, levels, maps in zip(regions, finer, self._read_blocks(regions))
                    for part, part_maps, rows in self._parts(region, maps, levels)]
        return [shooter for shooter in shooters if shooter is not None]

    def _read_blocks(self, regions):
        """Per region: its position (N, 4), normal (N, 3), unshot (N, 4) and surface number (N)
        as float64 rows, queued into one staging buffer and read back once."""
        offset, views = 0, []
        for page_index, x0, y0, size in regions:
            page = self._pages[page_index]
            width, height = min(size, self._packed.width - x0), min(size, self._packed.height - y0)
            count = width * height
            for attachment, components in BLOCK_MAPS:
                page.blocks.read_into(self._staging, viewport=(x0, y0, width, height),
                                      components=components, attachment=attachment, dtype="f4",
                                      write_offset=offset)
                views.append((offset // 4, count, components))
                offset += count * components * 4
        data = np.frombuffer(self._staging.read(size=offset), dtype="f4").astype(np.float64)
        rows = [data[start:start + components * count].reshape(count, components)
                for start, count, components in views]
        return [(position, _decode_normals(normal), unshot,
                 np.floor(material[:, 3] * 65535.0 + 0.5), material[:, :3])   # decode_surface()
                for position, normal, unshot, material in zip(*(rows[i::4] for i in range(4)))]

    def _block_region(self, page_index, block, power):
        """(page, x0, y0, size) of the texels a block shoots from, and how many levels finer
        its parts shoot. A block carrying 4^k times a mean block's share of the emitted power
        or more shoots as sub-blocks k levels finer, down to single texels: a strong
        shooter's visibility from one centre would cut its penumbrae into steps (the Cornell
        box's light, 57 times a mean block; not a furnace's walls, nor an emitter that is half
        the scene's blocks). With the adaptive shooting level a weak block shoots as a coarser
        block around it."""
        level = self.settings.shoot_level
        ratio = power * self._shooting_blocks / max(self._emitted_scalar, 1e-30)
        finer = min(level, int(math.log(ratio, 4.0))) if ratio >= 4.0 else 0
        coarser = 0 if finer else self._coarser_levels(power)
        size = 1 << (level + coarser)
        return (page_index, (block[0] >> coarser) * size, (block[1] >> coarser) * size,
                size), finer

    def _parts(self, region, maps, finer):
        """The region, or its sub-blocks ``finer`` levels down, each with its rows of the
        maps (row-major within the sub-block, as _make_shooter reads them) and their indices
        in the region's."""
        if finer == 0:
            yield region, maps, np.arange(len(maps[0]))
            return
        page_index, x0, y0, size = region
        width, height = min(size, self._packed.width - x0), min(size, self._packed.height - y0)
        part = size >> finer
        index = np.arange(width * height)
        column, row = index % width, index // width
        for y in range(0, height, part):
            for x in range(0, width, part):
                rows = index[(column >= x) & (column < x + part) & (row >= y) & (row < y + part)]
                yield (page_index, x0 + x, y0 + y, part), [values[rows] for values in maps], rows

    def _charts_of(self, region, maps, rows):
        """For a part of ``region`` (its ``rows`` of the region's maps): the chart of each of
        its texels and the charts' lightmap-to-world maps (_region_charts). Texels do not
        move, so once per region."""
        charts = self._region_charts.get(region)
        if charts is None:
            page_index, x0, y0, size = region
            charts = self._region_charts[region] = _region_charts(
                maps[0], maps[2][:, 3], min(size, self._packed.width - x0), (x0, y0))
        labels, by_label = charts
        return labels[rows], by_label

    def _make_shooter(self, region, maps, charts):
        """The shooter of a block from its maps: the coplanar part of the block around its
        strongest texel with similar unshot radiance (blocks at coarse levels may also hold
        texels of other charts, which keep their energy)."""
        page_index, x0, y0, size = region
        page = self._pages[page_index]
        width = min(size, self._packed.width - x0)
        position, normal, unshot, surface, albedo = maps
        area, radiance, texel_size = position[:, 3], unshot[:, :3], unshot[:, 3]
        power = radiance.mean(axis=1) * area
        strongest = int(np.argmax(power))
        if power[strongest] <= 0.0:
            return None
        n0, p0 = normal[strongest], position[strongest, :3]
        density = power / np.maximum(area, 1e-30)
        coplanar = ((power > 0.0) & (normal @ n0 > 0.95)
                    & (np.abs((position[:, :3] - p0) @ n0) <= 0.25 * size * texel_size[strongest]))
        members = np.nonzero(coplanar & (density >= SIMILAR_RADIANCE * density[strongest]))[0]
        members = self._same_side_as(region, strongest, members, position, texel_size[strongest])
        members = _rectangle_around(members, strongest, width, len(area) // width)
        weights = area[members, None]
        total_area = float(weights.sum())
        centre = (position[members, :3] * weights).sum(axis=0) / total_area
        n = (normal[members] * weights).sum(axis=0)
        n /= np.linalg.norm(n)
        texels = np.stack([members % width, members // width], axis=1)
        t = _lightmap_tangent(texels, position[members, :3], n)
        b = np.cross(n, t)
        taken = unshot[members].astype(np.float32)
        taken[:, 3] = 0.0   # the texel size stays
        labels, by_label = charts
        chart = by_label.get(int(labels[strongest]))
        if chart is not None:
            quad = _chart_quad(texels + (x0, y0), position[members, :3], chart, total_area)
        else:
            quad = _shooter_quad(position[members, :3] - centre, texel_size[members], t, b,
                                 total_area, centre)
        return _Shooter(
            page=page, texels=texels + (x0, y0),
            centre=centre, frame=np.stack([t, b, n], axis=1), area=total_area, quad=quad,
            radiance=(radiance[members] * weights).sum(axis=0) / total_area, unshot=taken,
            extent=(self._surface_extent(int(surface[strongest]), centre, t, b)
                    if self._thin_gap_near(region, position, normal, texel_size) else None),
            albedo=(albedo[members] * weights).sum(axis=0) / total_area)

    def _surface_extent(self, surface, centre, t, b):
        """The rectangle (u min, u max, v min, v max) along t and b from ``centre`` that holds
        the shooter's surface (all surfaces of its number), or an empty one for a shooter that
        does not receive (its texels hold no number)."""
        if surface <= 0:
            return NO_SURFACE
        offsets = self._corners_of(surface).reshape(-1, 3) - centre
        u, v = offsets @ t, offsets @ b
        return (float(u.min()), float(u.max()), float(v.min()), float(v.max()))

    def _corners_of(self, surface):
        """The corners (T, 3, 3) of the triangles of a surface number."""
        corners = self._surface_corners.get(surface)
        if corners is None:
            corners = self._surface_corners[surface] = self.scene.vertices[
                self.scene.triangles[self._surfaces == surface]]
        return corners

    def _thin_gap_near(self, region, position, normal, texel_size):
        """Whether a receiving triangle faces some texel of the region across a gap under
        twice SANDWICH_GAP of the largest texel (receivers' texels differ a little in size),
        within the near field's reach: a superset of the receivers that receive_patch.frag
        treats as across a thin gap. Texels do not move, so once per region."""
        thin = self._thin_gaps.get(region)
        if thin is None:
            occupied = position[:, 3] > 0.0
            points, normals = position[occupied, :3], normal[occupied]
            largest = float(texel_size[occupied].max())   # a shooter has its strongest texel
            gap, reach = 2.0 * SANDWICH_GAP * largest, 3.0 * largest
            receivers = self._receivers
            near = receivers.within(points.min(axis=0) - reach, points.max(axis=0) + reach)
            facing = receivers.normals[near] @ normals.T < -0.99               # (near, points)
            # How far in front of each texel each plane lies: a sheet's own back face, at 0,
            # gets nothing from its front.
            heights = receivers.normals[near] @ points.T - receivers.offsets[near, None]
            thin = self._thin_gaps[region] = bool(
                (facing & (heights > self._epsilon) & (heights < gap)).any())
        return thin

    def _same_side_as(self, region, strongest, members, position, texel_size):
        """The members on the strongest texel's side of every occluder whose plane runs
        through the block (a wall standing on the floor, a shelf touching a cabinet): shot
        from one centre, texels on both sides would light each side from the other. The
        others stay unshot for a later shot."""
        if len(members) < 2:
            return members
        points = position[:, :3]
        if region not in self._crossing_planes:   # blocks are shot many times: once per block
            self._crossing_planes[region] = self._planes_crossing(
                points[position[:, 3] > 0.0], texel_size)
        normals, offsets = self._crossing_planes[region]
        if len(offsets) == 0:
            return members
        sides = points[members] @ normals.T - offsets                    # (members, planes)
        own_side = np.sign(points[strongest] @ normals.T - offsets)
        return members[(sides * own_side >= -CROSSING_MARGIN * texel_size).all(axis=1)]

    def _planes_crossing(self, points, texel_size):
        """Planes (normals, offsets) of the occluders near ``points`` that have some of them
        on each side."""
        occluders = self._occluders
        near = occluders.within(points.min(axis=0) - texel_size, points.max(axis=0) + texel_size)
        normals, offsets = occluders.normals[near], occluders.offsets[near]
        sides = points @ normals.T - offsets
        margin = CROSSING_MARGIN * texel_size
        crossing = (sides.max(axis=0) > margin) & (sides.min(axis=0) < -margin)
        return normals[crossing], offsets[crossing]

    def _maybe_subdivide(self, power, clip_below):
        self._strongest_shot = max(self._strongest_shot, power)
        if (self.settings.subdivision == "ADAPTIVE"
                and power >= SUBDIVISION_MIN_SHARE * self._strongest_shot):
            self._timed("subdivision", self._subdivide_shadowed, clip_below)

    def _shoot_patch(self, shooter):
        shot_power = math.pi * shooter.area * shooter.radiance
        self._shot_power = self._shot_power + shot_power
        # The shooter looks from just above its surface and clips what lies behind it.
        eye = shooter.centre + shooter.frame[:, 2] * self._epsilon
        self._timed("visibility", self._render_visibility, eye, shooter.frame, 5, True, False)
        self._maybe_subdivide(float(np.mean(shot_power)), True)
        self._take_unshot(shooter)
        program = self._programs["patch"]
        _set(program, "u_quad", [tuple(corner) for corner in shooter.quad])
        _set(program, "u_centre", tuple(shooter.centre))
        _set(program, "u_radiance", tuple(shooter.radiance))
        # An empty rectangle: no texel is across a thin gap from this shooter.
        _set(program, "u_surface_extent",
             NO_SURFACE if shooter.extent is None else shooter.extent)
        self._timed("receivers", self._update_receivers, "patch")
        if shooter.extent is not None:
            self._timed("receivers", self._close_thin_gap, shooter)

    def _close_thin_gap(self, shooter):
        """Light the receivers facing the shooter across a thin gap, their sample points within
        a texel of its surface's rectangle (the texels the receiver pass left out:
        receive_patch.frag, sandwiched(); beside the surface, the light leaking out of the gap),
        with all the gap's bounces at once. Between facing surfaces far closer than a texel,
        light shot at a point bounces between the two at that point until absorbed: a receiver
        of albedo rho_r over a shooter of albedo rho_s shows pi L / (1 - rho_r rho_s) and
        reflects none of it out. What arrives is pi L times the share of its square under what
        the shooter's texels cover (_lit_by: the shooters of a surface tile it exactly, where
        their quads, rectangles of their texels' area, leave holes along a slanted edge). What
        it shows is the share of the middle of its square (SHOWN_SQUARE) under them, less the
        band along the surface's open edges where the gap's light leaks out."""
        t, b, n = shooter.frame.T
        centre = shooter.centre
        plane = np.stack([t, b], axis=1)
        polygons, segments = self._lit_by(shooter)
        if not polygons:
            return
        lit = [(polygon - centre) @ plane for polygon in polygons]
        corners = np.concatenate(lit)
        reach = float(np.linalg.norm(corners, axis=1).max())   # in_near_field()
        low, high = corners.min(axis=0), corners.max(axis=0)
        # As complex coordinates along t and b (thin_gaps).
        lit = [[complex(x, y) for x, y in polygon] for polygon in lit]
        open_edges = []
        for segment in segments:   # each with the surface on its left
            start, end, inner = (complex(x, y) for x, y in (segment - centre) @ plane)
            left = ((end - start).conjugate() * (inner - start)).imag > 0.0
            open_edges.append((start, end) if left else (end, start))
        u_min, u_max, v_min, v_max = shooter.extent
        for page, texels in zip(self._pages, self._texels_on_pages()):
            near = texels.near(centre, reach)
            offsets = texels.position[near] - centre
            height, u, v = offsets @ n, offsets @ t, offsets @ b
            side, normal = texels.side[near], texels.normal[near]
            corner = math.sqrt(0.5) * side   # how far a texel's square reaches from its point
            inside = np.nonzero(
                (height > self._epsilon) & (height < SANDWICH_GAP * side)
                & ((normal * offsets).sum(axis=1) < 0.0) & (normal @ n < -0.99)
                & (np.linalg.norm(offsets, axis=1) < reach + 2.0 * side)
                & (u >= u_min - side) & (u <= u_max + side)
                & (v >= v_min - side) & (v <= v_max + side)
                & (u + corner >= low[0]) & (u - corner <= high[0])
                & (v + corner >= low[1]) & (v - corner <= high[1]))[0]
            if not len(inside):
                continue
            chosen = near[inside]
            halves = square_halves(normal[inside], side[inside], t, b)
            points = u[inside] + 1j * v[inside]
            under = np.array([share_under(square(point, half_t, half_b), lit)
                              for point, half_t, half_b in zip(points, *halves)])
            middles = [square(point, SHOWN_SQUARE * half_t, SHOWN_SQUARE * half_b)
                       for point, half_t, half_b in zip(points, *halves)]
            shown_share = np.repeat([[share_under(middle, lit)] for middle in middles], 3, axis=1)
            albedo = texels.albedo[chosen].astype(np.float64)
            # Two albedos of 1 would keep the light for ever: at most 1,000 times.
            kept = np.minimum(albedo * shooter.albedo, 0.999)
            if open_edges:
                # Along an open edge the band where the light leaks out (thin_gaps.edge_band),
                # summed over the middle of the square chord by chord.
                cells, widths = band_cells()
                for row, (middle, gap) in enumerate(zip(middles, height[inside])):
                    chords = sum(chord_lengths(middle, start, end, cells * gap)
                                 for start, end in open_edges) * widths * gap / area(middle)
                    shown_share[row] -= [(edge_band(round(float(kept_share), 3)) * chords).sum()
                                         for kept_share in kept[row]]
                shown_share = np.clip(shown_share, 0.0, 1.0)
            texel_area = texels.area[chosen, None].astype(np.float64)
            shown = (math.pi * shooter.radiance * shown_share / (1.0 - kept)).astype(np.float32)
            self._add_irradiance(page, texels.xy[chosen], shown)
            self._gap_shown_received += (shown * texel_area).sum(axis=0)
            self._gap_shown_absorbed += ((1.0 - albedo) * shown * texel_area).sum(axis=0)
            arrived = math.pi * shooter.radiance * under[:, None] * texel_area
            self._gap_arrived += arrived.sum(axis=0)

    def _lit_by(self, shooter):
        """What a shooter's texels cover: world polygons (the triangles on its page clipped to
        its texels' rectangle in the lightmap, texel i spanning [i, i + 1), each mapped back to
        the world by its own affine map) and world segments (the open edges of its surface
        among them, _open_edges: their two ends and a point a texel inside). Blocks are shot
        many times: once per rectangle."""
        page = self._pages.index(shooter.page)
        (x0, y0), (x1, y1) = shooter.texels.min(axis=0), shooter.texels.max(axis=0) + 1
        key = (page, int(x0), int(y0), int(x1), int(y1))
        if key in self._lit_polygons:
            return self._lit_polygons[key]
        if self._page_triangles is None:
            atlas = self._packed
            corners = self.scene.vertices[self.scene.triangles[atlas.triangles]]
            open_edges = self._open_edges()
            self._page_triangles = [
                (atlas.texels[on], corners[on], open_edges[on], atlas.texels[on].min(axis=1),
                 atlas.texels[on].max(axis=1))
                for on in (atlas.page == index for index in range(atlas.page_count))]
        texels, corners, open_edges, low, high = self._page_triangles[page]
        meets = np.nonzero((low[:, 0] < x1) & (high[:, 0] > x0)
                           & (low[:, 1] < y1) & (high[:, 1] > y0))[0]
        rectangle = [complex(x0, y0), complex(x1, y0), complex(x1, y1), complex(x0, y1)]
        polygons, segments = [], []
        for triangle in meets:
            uv, points = texels[triangle], corners[triangle]
            outline = [complex(x, y) for x, y in uv]
            turn = signed_area(outline)
            if abs(turn) < 1e-12:
                continue
            piece = clipped(outline, rectangle)
            # A triangle touching the rectangle along a side or at a corner leaves a piece of
            # no area, whose outline would cover everything in thin_gaps.share_under.
            if len(piece) < 3 or abs(signed_area(piece)) <= 1e-9 * abs(turn):
                continue
            polygons.append(_texels_to_world(piece, uv, points))
            for corner in np.nonzero(open_edges[triangle])[0]:
                a, b = outline[corner], outline[(corner + 1) % 3]
                # An open edge often lies on its texels' outer side (xatlas fits some charts to
                # whole texels), a rounding error to either side: it belongs to the texels of
                # its triangle, so it is clipped a thousandth of a texel inside the triangle.
                inward = (b - a) * (1j if turn > 0 else -1j)
                inward *= 1e-3 / abs(inward)
                part = clipped_segment(a + inward, b + inward, rectangle)
                if part is not None:
                    # Its two ends and a point inside the triangle, which tells its side.
                    ends = [end - inward for end in part]
                    segments.append(_texels_to_world(
                        ends + [0.5 * (ends[0] + ends[1]) + 1e3 * inward], uv, points))
        self._lit_polygons[key] = polygons, segments
        return polygons, segments

    def _open_edges(self):
        """Per charted triangle, whether each edge (corner i to i + 1) is open: no other
        triangle of its surface, on the same side of the sheet, shares it. A thin gap's light
        leaks out there (thin_gaps.edge_band)."""
        scene, atlas = self.scene, self._packed
        ends = np.round(scene.vertices[scene.triangles[atlas.triangles]] / self._epsilon)
        ends = ends.astype(np.int64)
        starts, stops = ends, np.roll(ends, -1, axis=1)                      # (C, 3, 3)
        # Each edge's two ends in one order: the lesser (lexicographically) first.
        later = np.zeros(starts.shape[:2], dtype=bool)
        for axis in (2, 1, 0):
            later = np.where(starts[..., axis] == stops[..., axis], later,
                             starts[..., axis] > stops[..., axis])
        first = np.where(later[..., None], stops, starts)
        second = np.where(later[..., None], starts, stops)
        back = (scene.back_of[atlas.triangles] >= 0 if scene.back_of is not None
                else np.zeros(len(atlas.triangles), dtype=bool))
        sheet = np.repeat((2 * self._surfaces[atlas.triangles] + back)[:, None, None], 3, axis=1)
        keys = np.concatenate([sheet, first, second], axis=2).reshape(-1, 7)
        _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
        return (counts[inverse.ravel()] == 1).reshape(-1, 3)

    def _texels_on_pages(self):
        """Per page, its receiving texels (_Texels), read back once."""
        if self._receiving_texels is None:
            self._receiving_texels = []
            for page in self._pages:
                position = self._read(page.textures["position"])
                material = self._read(page.textures["material"])
                occupied = (position[..., 3] > 0.0) & (material[..., 3] > 0.0)
                y, x = np.nonzero(occupied)
                order = np.argsort(position[y, x, 0], kind="stable")
                y, x = y[order], x[order]
                area = position[y, x, 3]
                self._receiving_texels.append(_Texels(
                    xy=np.stack([x, y], axis=1), position=position[y, x, :3].astype(np.float64),
                    normal=_decode_normals(self._read(page.textures["normal"])[y, x]),
                    side=np.sqrt(area.astype(np.float64)), area=area, albedo=material[y, x, :3],
                    largest_side=float(np.sqrt(area.max(initial=0.0)))))
        return self._receiving_texels

    def _add_irradiance(self, page, texels, irradiance):
        """Add (N, 3) irradiance to the texels (N, 2) of a page, leaving their unshot light."""
        page.receivers.color_mask = [(True,) * 4, (False,) * 4]
        values = np.zeros((len(texels), 4), dtype=np.float32)
        values[:, :3] = irradiance
        self._blend_points(page.receivers, texels, values, moderngl.FUNC_ADD)
        page.receivers.color_mask = [(True,) * 4, (True,) * 4]

    def _blend_points(self, framebuffer, texels, values, equation):
        """Blend (N, 4) values into the texels (N, 2) of a framebuffer's first attachment by
        ``equation``, one point each (take_unshot.*)."""
        points = np.concatenate([texels, values], axis=1).astype(np.float32)
        if points.nbytes > self._points_vbo.size:
            self._points_vbo.orphan(points.nbytes)
        self._points_vbo.write(points.tobytes())
        framebuffer.use()
        ctx = self.ctx
        ctx.enable(moderngl.BLEND)
        ctx.blend_equation = equation
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        self._points_vao.render(moderngl.POINTS, vertices=len(points))
        ctx.blend_equation = moderngl.FUNC_ADD
        ctx.disable(moderngl.BLEND)

    def _shoot_light(self, light):
        program = self._programs["light"]
        power = self._light_power(light)
        if isinstance(light, SunLight):
            n = np.asarray(light.direction, dtype=np.float64)
            n /= np.linalg.norm(n)
            frame = _frame_around(n)
            eye = self._centre - n * self._radius
            _set(program, "u_light_kind", 2)
            _set(program, "u_light_value", tuple(light.irradiance()))
            self._timed("visibility", self._render_visibility, eye, frame, 1, False, True)
            self._sunlight_missed += float(np.mean(power)) * (1.0 - self._covered_share())
        else:
            eye = np.asarray(light.position, dtype=np.float64)
            _set(program, "u_light_kind", 0)
            _set(program, "u_light_value", tuple(light.intensity()))
            if isinstance(light, SpotLight):
                axis = np.asarray(light.direction, dtype=np.float64)
                _set(program, "u_light_kind", 1)
                _set(program, "u_spot_axis", tuple(axis / np.linalg.norm(axis)))
                _set(program, "u_spot_cos_half", light.cos_half_angle())
                _set(program, "u_spot_smooth", light.smooth_width())
            self._timed("visibility", self._render_visibility, eye, np.eye(3), 6, False, False)
        self._maybe_subdivide(float(np.mean(power)), False)
        self._shot_power = self._shot_power + power
        self._timed("receivers", self._update_receivers, "light")

    def _light_power(self, light):
        if isinstance(light, SunLight):
            return light.irradiance() * (2.0 * self._radius) ** 2
        return light.emitted_power()

    def _view_uniforms(self, program, eye, frame, orthographic):
        _set(program, "u_eye", tuple(eye))
        _set(program, "u_frame", tuple(np.asarray(frame, dtype=np.float64).T.ravel()))
        _set(program, "u_orthographic", int(orthographic))
        _set(program, "u_near", 1e-6 * self._radius if not orthographic else 0.0)
        _set(program, "u_far", 4.0 * self._radius + float(np.linalg.norm(eye - self._centre)))
        _set(program, "u_hemisphere", int(self.settings.projection != "HEMICUBE"
                                          and not orthographic))

    def _render_visibility(self, eye, frame, faces, clip_below, orthographic):
        """Distance map around the eye: ``faces`` cube faces (6 all round, 5 the hemicube in
        front, 1 the sun's orthographic view) or, with a hemisphere projection, the front
        hemisphere alone or both."""
        hemisphere = self.settings.projection != "HEMICUBE" and not orthographic
        name = "visibility"
        if hemisphere and self.settings.projection == "NONLINEAR":
            name = "nonlinear"
        elif hemisphere:
            # Subdivision also tessellates casters: the per-vertex projection draws their
            # edges straight, misplacing shadow boundaries (the paper's Figure 5).
            name = "hemisphere_tessellated" if self.settings.subdivision != "NONE" else "hemisphere"
        program = self._programs[name]
        self._view_uniforms(program, eye, frame, orthographic)
        _set(program, "u_face_count", (2 if faces == 6 else 1) if hemisphere else faces)
        _set(program, "u_clip_below", int(clip_below))
        self._view = (eye, frame, orthographic)
        ctx = self.ctx
        self._visibility_fbo.use()
        self._visibility_fbo.clear(3.0e38, 3.0e38, 3.0e38, 3.0e38)
        clip = clip_below or name.startswith("hemisphere")
        if clip:
            ctx.enable_direct(0x3000)  # GL_CLIP_DISTANCE0
        ctx.enable(moderngl.BLEND)
        ctx.blend_equation = moderngl.MIN
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        self._visibility_vaos[name].render(moderngl.TRIANGLES, vertices=self._triangle_vertices)
        ctx.blend_equation = moderngl.FUNC_ADD
        ctx.disable(moderngl.BLEND)
        if clip:
            ctx.disable_direct(0x3000)

    def _covered_share(self):
        """The share of the first visibility map's texels that something was drawn into (the
        sun's window the scene covers)."""
        texels = self._map_size ** 2
        distances = np.frombuffer(self._visibility.read(), dtype="f4")[:2 * texels:2]
        return float(np.count_nonzero(distances < 1e38)) / texels

    def _take_unshot(self, shooter):
        """Subtract what the shot took from its texels' unshot energy (exactly the values it
        read, so energy they received since stays)."""
        self._blend_points(shooter.page.unshot_only, shooter.texels, shooter.unshot,
                           moderngl.FUNC_REVERSE_SUBTRACT)
        emitting, power = shooter.page.emission_left
        if len(emitting):
            flat = shooter.texels[:, 1].astype(np.int64) * self._packed.width + shooter.texels[:, 0]
            where = np.searchsorted(emitting, flat).clip(0, len(emitting) - 1)
            power[where[emitting[where] == flat]] = 0.0

    def _update_receivers(self, kind):
        program = self._programs[kind]
        eye, frame, orthographic = self._view
        self._view_uniforms(program, eye, frame, orthographic)
        ctx = self.ctx
        ctx.enable(moderngl.BLEND)
        ctx.blend_equation = moderngl.FUNC_ADD
        ctx.blend_func = moderngl.ONE, moderngl.ONE
        self._visibility.use(location=0)
        for page in self._pages:
            page.receivers.use()
            page.textures["position"].use(location=1)
            page.textures["normal"].use(location=2)
            page.textures["material"].use(location=3)
            page.textures["level"].use(location=4)
            self._fullscreen[kind].render(moderngl.TRIANGLES, vertices=3)
        ctx.disable(moderngl.BLEND)

    # ----------------------------------------------------------------- postprocess
    def _postprocess(self):
        """Per page: rho * (E / pi + ambient) on receiving texels, alpha 1, and the gutter
        filled, on the CPU from the maps it reads anyway (no output maps on the GPU)."""
        # Whole RGBA rows are contiguous (fast); the irradiance's alpha is 0 throughout.
        irradiance = [self._read(page.textures["irradiance"]) for page in self._pages]
        ambient = self._ambient(irradiance) if self.settings.ambient else np.zeros(3)
        pages = []
        for page, image in zip(self._pages, irradiance):
            material = self._read(page.textures["material"])
            occupied = material[..., 3] > 0   # a receiving texel (rasterized: area > 0)
            image *= np.float32(1.0 / math.pi)
            image += np.append(ambient, 0.0).astype(np.float32)
            image *= material
            image *= occupied[..., None]
            image[..., 3] = occupied
            image = self._in_atlas_layout(page, image)
            _fill_gutter(image, self.settings.padding + 1)
            pages.append(image)
        return pages

    # ----------------------------------------------------------------- helpers
    def _read(self, texture):
        """A map as float32 (height, width, components), or (height, width) for one
        component; normalized integer maps scaled to [0, 1] as the shaders read them."""
        dtype = texture.dtype.lstrip("n")
        data = np.frombuffer(texture.read(), dtype=dtype).astype(np.float32)
        if texture.dtype.startswith("n"):
            data /= np.iinfo(dtype).max
        shape = (texture.height, texture.width, texture.components)
        return data.reshape(shape).squeeze(axis=2) if texture.components == 1 else data.reshape(shape)

    def _finish(self):
        if self.settings.profile:
            self.ctx.finish()

    def _timed(self, phase, function, *args):
        start = time.perf_counter()
        try:
            return function(*args)
        finally:
            self._finish()
            self.timings[phase] += time.perf_counter() - start


class _TrianglePlanes:
    """Planes and bounds of triangles ((T, 3, 3) corners), and which of them meet a box."""

    def __init__(self, corners):
        normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        self.normals = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-30)
        self.offsets = (self.normals * corners[:, 0]).sum(axis=1)
        self.low, self.high = corners.min(axis=1), corners.max(axis=1)
        self.centres = corners.mean(axis=1)
        self.radii = np.linalg.norm(corners - self.centres[:, None], axis=2).max(axis=1)
        # Looked up among the smaller 95 % sorted by x, plus the largest 5 % always: a lookup
        # then tests hundreds of triangles, not the whole scene.
        self._reach = float(np.quantile(self.radii, 0.95)) if len(self.radii) else 0.0
        small = self.radii <= self._reach
        self._small = np.nonzero(small)[0][np.argsort(self.centres[small, 0])]
        self._small_x = self.centres[self._small, 0]
        self._large = np.nonzero(~small)[0]

    def within(self, low, high):
        """The triangles whose bounds meet the box from ``low`` to ``high``."""
        first, last = np.searchsorted(self._small_x, [low[0] - self._reach,
                                                      high[0] + self._reach])
        candidates = np.concatenate([self._small[first:last], self._large])
        return candidates[(self.low[candidates] <= high).all(axis=1)
                          & (self.high[candidates] >= low).all(axis=1)]


def smooth_surfaces(scene):
    """A number per triangle for the smooth surface it belongs to: triangles joined across
    shared edges that bend by less than SMOOTH_SURFACE_DEGREES (a curved mesh's facets are
    one surface; a box's faces, or a wall and the floor it stands on, are several), and the
    triangles of one object in one plane (pieces meeting at T-junctions). The visibility test
    forgives a receiver small depth differences against its own surface only."""
    corners = scene.vertices[scene.triangles]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    count = len(scene.triangles)
    edges = np.sort(scene.triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    owners = np.repeat(np.arange(count), 3)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    edges, owners = edges[order], owners[order]
    shared = np.nonzero((edges[1:] == edges[:-1]).all(axis=1))[0]
    a, b = owners[shared], owners[shared + 1]
    smooth = (normals[a] * normals[b]).sum(axis=1) > math.cos(math.radians(SMOOTH_SURFACE_DEGREES))
    a, b = a[smooth], b[smooth]
    lo, hi = scene.bounds()
    step = 1e-5 * max(float(np.linalg.norm(hi - lo)), 1e-9)
    plane = np.column_stack([scene.object_index, np.round(normals * 1e4),
                             np.round((normals * corners[:, 0]).sum(axis=1) / step)])
    _, first, group = np.unique(plane, axis=0, return_index=True, return_inverse=True)
    a, b = np.concatenate([a, np.arange(count)]), np.concatenate([b, first[group.ravel()]])
    label = np.arange(count)
    while True:   # connected components: pull both ends to the smaller label, then jump
        joined = np.minimum(label[a], label[b])
        previous = label.copy()
        np.minimum.at(label, a, joined)
        np.minimum.at(label, b, joined)
        label = label[label]
        if np.array_equal(label, previous):
            return np.unique(label, return_inverse=True)[1]


def _lower_to(density, current=None):
    """The fix a GPUMemoryError gives: a density checked to fit, or the memory to raise."""
    if density is None:
        return ("no texel density fits: raise the memory limit or give fewer objects a "
                "lightmap")
    start = "" if current is None else f"from {current:.4g} "
    return f"lower the texel density {start}to {density:.4g} texels per metre or less"


def sky_suns(radiance, count):
    """A uniform sky of ``radiance`` as ``count`` suns on a Fibonacci sphere, each carrying the
    irradiance of its 4 pi / count share of directions: radiance * 4 pi / count."""
    radiance = np.asarray(radiance, dtype=np.float64)
    if radiance.max() <= 0.0:
        return []
    index = np.arange(count) + 0.5
    z = 1.0 - 2.0 * index / count
    azimuth = math.pi * (3.0 - math.sqrt(5.0)) * index
    ring = np.sqrt(1.0 - z * z)
    directions = np.stack([ring * np.cos(azimuth), ring * np.sin(azimuth), z], axis=1)
    strength = float(radiance.max()) * 4.0 * math.pi / count
    color = tuple(radiance / radiance.max())
    return [SunLight(tuple(d), strength, color, name="World") for d in directions]


def _fill_gutter(image, passes):
    """Gutter fill, ``passes`` rings deep: an empty texel next to filled ones takes their
    mean, so bilinear sampling across chart borders shows no seams; alpha stays 0 there."""
    height, width = image.shape[:2]
    filled = image[..., 3] > 0
    offsets = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx]
    for _ in range(passes):
        padded = np.pad(filled, 1)
        touched = np.zeros_like(filled)
        for dy, dx in offsets:
            touched |= padded[1 + dy:1 + dy + height, 1 + dx:1 + dx + width]
        ys, xs = np.nonzero(touched & ~filled)
        if not len(ys):
            return
        total, count = np.zeros((len(ys), 3)), np.zeros(len(ys))
        for dy, dx in offsets:
            ny, nx = ys + dy, xs + dx
            inside = (ny >= 0) & (ny < height) & (nx >= 0) & (nx < width)
            ny, nx = np.clip(ny, 0, height - 1), np.clip(nx, 0, width - 1)
            use = inside & filled[ny, nx]
            total += image[ny, nx, :3] * use[:, None]
            count += use
        image[ys, xs, :3] = total / count[:, None]
        filled[ys, xs] = True


def _decode_normals(stored):
    """Unit normals from the octahedral normal map's values in [0, 1] (texel_maps.glsl)."""
    p = (np.floor(stored[..., :2].astype(np.float64) * 65535.0 + 0.5) - OCT_STEPS) / OCT_STEPS
    z = 1.0 - np.abs(p).sum(axis=-1)
    folded = (1.0 - np.abs(p[..., ::-1])) * np.where(p >= 0.0, 1.0, -1.0)
    xy = np.where((z < 0.0)[..., None], folded, p)
    n = np.concatenate([xy, z[..., None]], axis=-1)
    return n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-30)


def _bent_normal_codes(normal_sum, moments, sample_normals):
    """The normal map's third and fourth channels (RGBA16) of texels whose surface bends
    within them, from sums over their covered shares c: c n and c (normal_sum), and c tt,
    c bb, c tb (moments), t and b the normal's components along tangent_of(s) and s x
    tangent_of(s) for the sample's normal s. The spread is the mean normal's length; the
    receivers (texel_maps.glsl decode_bend) gather at the mean normal's direction turned by
    acos(spread) each way along the bend, given as the heading of a tangent of s (from
    tangent_of(s) towards s x tangent_of(s)) and the tilt from s along it to the mean. The
    bend runs from s towards the mean, or where s is the mean, along the principal axis of
    the moments: where the normals vary most."""
    covered = normal_sum[:, 3:4]
    mean = normal_sum[:, :3] / covered
    spread = np.linalg.norm(mean, axis=1)
    mean /= spread[:, None]
    tt, bb, tb = (moments[:, i] / covered[:, 0] for i in range(3))
    principal_heading = 0.5 * np.arctan2(2.0 * tb, tt - bb)
    t = _tangents_of(sample_normals)
    b = np.cross(sample_normals, t)
    along = (mean * sample_normals).sum(axis=1)
    towards = mean - along[:, None] * sample_normals
    apart = np.linalg.norm(towards, axis=1)
    bends_away = apart > BEND_DIRECTION_SINE
    heading = np.where(bends_away, np.arctan2((towards * b).sum(axis=1),
                                              (towards * t).sum(axis=1)), principal_heading)
    tilt = np.where(bends_away, np.arctan2(apart, along), 0.0)
    heading_code = np.round((heading / (2.0 * math.pi) + 0.5) * BEND_STEPS)
    tilt_code = np.round(np.clip(tilt / (0.5 * math.pi), 0.0, 1.0) * BEND_STEPS)
    return np.stack([np.round(spread * 65535.0),
                     heading_code * (BEND_STEPS + 1) + tilt_code], axis=1).astype(np.uint16)


def _tangents_of(normals):
    """tangent_of() (texel_maps.glsl) of each row of ``normals``."""
    axes = np.eye(3)[np.argmin(np.abs(normals), axis=1)]
    t = axes - normals * (axes * normals).sum(axis=1, keepdims=True)
    return t / np.linalg.norm(t, axis=1, keepdims=True)


def _texels_to_world(texel_points, uv, corners):
    """Complex texel-space points of a triangle (its corners ``uv`` in texels, ``corners`` in
    the world) in the world, by its affine map. Plain arithmetic: numpy's small solves and
    products wait on its threads, which contend with llvmpipe's."""
    (u0, v0), (u1, v1), (u2, v2) = uv
    det = (u1 - u0) * (v2 - v0) - (u2 - u0) * (v1 - v0)
    offsets = [(point.real - u0, point.imag - v0) for point in texel_points]
    first = np.array([(du * (v2 - v0) - dv * (u2 - u0)) / det for du, dv in offsets])
    second = np.array([(dv * (u1 - u0) - du * (v1 - v0)) / det for du, dv in offsets])
    return (corners[0] + first[:, None] * (corners[1] - corners[0])
            + second[:, None] * (corners[2] - corners[0]))


def _lightmap_tangent(texels, positions, n):
    """The world direction of +x in the lightmap over a shooter's texels (so that its quad
    lines up with them), by least squares of their positions on their texel coordinates;
    along +y turned a quarter when they span one column, tangent_of(n) for one texel."""
    spans = [texels[:, axis].min() < texels[:, axis].max() for axis in (0, 1)]
    if not any(spans):
        return _tangents_of(n[None])[0]
    design = np.column_stack([np.ones(len(texels)), texels[:, [i for i in (0, 1) if spans[i]]]])
    slopes = np.linalg.lstsq(design, positions, rcond=None)[0][1:]
    direction = slopes[0] if spans[0] else np.cross(slopes[0], n)
    direction = direction - n * (direction @ n)
    length = np.linalg.norm(direction)
    return direction / length if length > 1e-12 else _tangents_of(n[None])[0]


def _rectangle_around(members, strongest, width, height):
    """The members in a rectangle of texels grown around the strongest while whole rows and
    columns of members border it: a shooter's quad must lie where its texels are, or the
    receivers next to it (a ceiling 0.1 mm over a lamp) get the light of the wrong place.
    The members left out stay unshot for a later shot."""
    columns, rows = members % width, members // width
    if len(members) == (np.ptp(columns) + 1) * (np.ptp(rows) + 1):
        return members   # a rectangle already (and so around the strongest)
    mask = np.zeros((height, width), dtype=bool)
    mask.flat[members] = True
    x0 = x1 = strongest % width
    y0 = y1 = strongest // width
    grown = True
    while grown:
        grown = False
        if x0 > 0 and mask[y0:y1 + 1, x0 - 1].all():
            x0, grown = x0 - 1, True
        if x1 < width - 1 and mask[y0:y1 + 1, x1 + 1].all():
            x1, grown = x1 + 1, True
        if y0 > 0 and mask[y0 - 1, x0:x1 + 1].all():
            y0, grown = y0 - 1, True
        if y1 < height - 1 and mask[y1 + 1, x0:x1 + 1].all():
            y1, grown = y1 + 1, True
    rows, columns = np.mgrid[y0:y1 + 1, x0:x1 + 1]
    return (rows * width + columns).ravel()


# Slices of a (rows, columns) grid: each texel and its neighbour along x, then along y.
_NEIGHBOURS = (((slice(None), slice(1, None)), (slice(None), slice(None, -1))),
               ((slice(1, None), slice(None)), (slice(None, -1), slice(None))))


def _region_charts(position, texel_size, width, origin):
    """The charts in a read region and how each maps the lightmap to the world. Texels are
    joined through occupied neighbours (xatlas pads charts apart). Per chart with whole
    texels next to each other along both lightmap axes: (anchor, its texel, step x, step y,
    inverse), world = anchor + (texel - its texel) @ (step x, step y), the steps being the
    mean world step between neighbouring whole texels (xatlas may scale a chart's axes
    differently: the Cornell light's texels are 16.25 x 15 mm). Returns (label per texel,
    {label: that tuple})."""
    height = len(position) // width
    points = position[:, :3].reshape(height, width, 3)
    occupied = (position[:, 3] > 0.0).reshape(height, width)
    whole = (position[:, 3] >= 0.999 * texel_size ** 2).reshape(height, width) & occupied
    labels = np.where(occupied, np.arange(height * width).reshape(height, width), -1)
    while True:   # each texel takes the least label among its occupied neighbours
        before = labels.copy()
        for a, b in _NEIGHBOURS:
            joined = occupied[a] & occupied[b]
            labels[a] = np.where(joined, np.minimum(labels[a], before[b]), labels[a])
            labels[b] = np.where(joined, np.minimum(labels[b], before[a]), labels[b])
        if np.array_equal(before, labels):
            break
    steps = []
    for a, b in _NEIGHBOURS:   # along the lightmap's x (columns), then y (rows)
        pairs = whole[a] & whole[b] & (labels[a] == labels[b])
        steps.append((labels[b][pairs], (points[a] - points[b])[pairs]))
    charts = {}
    for label in np.unique(labels[whole]):
        along = [differences[owners == label] for owners, differences in steps]
        if len(along[0]) == 0 or len(along[1]) == 0:
            continue
        step_x, step_y = along[0].mean(axis=0), along[1].mean(axis=0)
        row, column = np.argwhere(whole & (labels == label))[0]
        basis = np.stack([step_x, step_y], axis=1)
        charts[int(label)] = (points[row, column], np.array([origin[0] + column,
                                                             origin[1] + row], dtype=np.float64),
                              basis, np.linalg.pinv(basis))
    return labels.ravel(), charts


def _chart_quad(texels, points, chart, area):
    """A shooter's quad from its texels' rectangle (page texel coordinates) mapped to the
    world by their chart: neighbouring shooters' quads tile the surface as the texels do.
    A part-covered texel at the rectangle's side covers the side of its texel away from the
    chart's edge, its sample point in the middle of what it covers: the quad's side is moved
    in to match. Scaled to the texels' exact area about its middle."""
    anchor, anchor_texel, basis, inverse = chart
    at = (points - anchor) @ inverse.T + anchor_texel   # sample points, in texels
    sides = []
    for axis in (0, 1):
        low, high = texels[:, axis].min(), texels[:, axis].max()
        first, last = texels[:, axis] == low, texels[:, axis] == high
        shift = at[:, axis] - texels[:, axis]
        # Toward the chart's inside a side stays on the texel's edge.
        sides.append((np.max(np.where(shift[first] > 0.0, 2.0 * at[first, axis] - low - 0.5,
                                      low - 0.5)),
                      np.min(np.where(shift[last] < 0.0, 2.0 * at[last, axis] - high + 0.5,
                                      high + 0.5))))
    (x0, x1), (y0, y1) = sides
    corners = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]) - anchor_texel
    world = anchor + corners @ basis.T
    middle = world.mean(axis=0)
    spanned = np.linalg.norm(np.cross(world[1] - world[0], world[3] - world[0]))
    scale = math.sqrt(area / max(spanned, 1e-30))
    return list(middle + (world - middle) * scale)


def _shooter_quad(offsets, texel_sizes, t, b, area, centre):
    """Rectangle in the shooter's plane spanning its texels, scaled to their exact area."""
    u, v = offsets @ t, offsets @ b
    half = 0.5 * texel_sizes
    u0, u1 = (u - half).min(), (u + half).max()
    v0, v1 = (v - half).min(), (v + half).max()
    scale = math.sqrt(area / max((u1 - u0) * (v1 - v0), 1e-30))
    hu, hv = 0.5 * (u1 - u0) * scale, 0.5 * (v1 - v0) * scale
    return [centre + sx * hu * t + sy * hv * b
            for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]


def _buffer_content(program, vbo, layout):
    """Vertex-array content for an interleaved buffer, skipping attributes the program's
    compiler removed as unused."""
    formats, names = [], []
    for name, count in layout:
        if program.get(name, None) is not None:
            formats.append(f"{count}f")
            names.append(name)
        else:
            formats.append(f"{4 * count}x")
    return (vbo, " ".join(formats), *names)


def _set(program, name, value):
    """Set a uniform unless the compiler removed it as unused (drivers differ)."""
    uniform = program.get(name, None)
    if uniform is not None:
        uniform.value = value


def _overlap(a, b):
    """Whether two (page, x0, y0, size) squares share a texel."""
    return (a[0] == b[0] and a[1] < b[1] + b[3] and b[1] < a[1] + a[3]
            and a[2] < b[2] + b[3] and b[2] < a[2] + a[3])


def _frame_around(n):
    """Orthonormal columns (t, b, n) with n the given unit vector."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t = np.cross(helper, n)
    t /= np.linalg.norm(t)
    return np.stack([t, np.cross(n, t), n], axis=1)


def _runs(slots):
    """(first, count) of each run of consecutive integers in sorted ``slots``."""
    breaks = np.nonzero(np.diff(slots) != 1)[0] + 1
    return [(int(run[0]), len(run)) for run in np.split(slots, breaks)]
