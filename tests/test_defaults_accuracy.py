"""What a user gets with the default settings (native.Settings()), on scenes of four kinds,
each against an independent truth: an open scene (Lambert's polygon formula), the shadows of
slats under it (the same less what they hide), two rooms sealed from each other (zero in the
dark one) and a closed room of albedo 0.99 (the furnace, rho / (1 - rho)). The ambient term
is on by default: these tests decide what it may add."""
import math

import numpy as np
import pytest

import analytic
from native import PointLight, Settings, Solver
from native.preprocess import AUTOMATIC_HEMICUBE, LEAST_MAP_DENSITY, hemicube_resolution
from native.samples import SceneBuilder


def bake(scene, ctx, shots=None, settings=None):
    """The defaults' lightmaps and texel samples: run to the end, or stopped after ``shots``
    (a user looking at a bake in progress)."""
    solver = Solver(scene, settings or Settings(), ctx=ctx)
    try:
        solver.run(None if shots is None else lambda progress: progress.shots < shots)
        return solver.result(), solver.texel_samples(), solver.progress
    finally:
        solver.release()


def occupied(images, samples):
    """Values, positions and normals of every occupied texel over all pages."""
    values = np.concatenate([image[s["occupied"]][:, :3] for image, s in zip(images, samples)])
    positions = np.concatenate([s["position"][s["occupied"]] for s in samples])
    normals = np.concatenate([s["normal"][s["occupied"]] for s in samples])
    return values, positions, normals


def test_open_scene_is_the_single_bounce_at_every_point(ctx, gl_clean):
    """A black 0.6 m emitter (radiance 1, facing down) 1 m over a 5 x 4 m floor of albedo
    0.6, nothing else: the floor's light has one bounce, rho * L * F with F from Lambert's
    formula at each texel's sample point, within 1 % everywhere, far corners included (what
    the floor reflects escapes: no ambient light may come back)."""
    albedo, radiance = 0.6, 1.0
    emitter = [(-0.1, -0.2, 1.0), (-0.1, 0.4, 1.0), (0.5, 0.4, 1.0), (0.5, -0.2, 1.0)]
    builder = SceneBuilder()
    builder.quad("floor", [(-2, -1.5, 0), (3, -1.5, 0), (3, 2.5, 0), (-2, 2.5, 0)],
                 (albedo,) * 3)
    builder.quad("emitter", emitter, (0.0,) * 3, (radiance,) * 3, two_sided=False)
    images, samples, progress = bake(builder.build(), ctx)
    assert progress.converged
    values, positions, normals = occupied(images, samples)
    floor = (np.abs(positions[:, 2]) < 1e-4) & (normals[:, 2] > 0.99)
    assert floor.sum() > 6000
    truth = albedo * radiance * analytic.polygon_form_factors(positions[floor], normals[floor],
                                                              emitter)
    relative = values[floor] / truth[:, None] - 1.0
    assert np.abs(relative).max() < 0.01, (relative.min(), relative.max())


def test_shadow_edges_stay_where_the_occluder_casts_them(ctx, gl_clean):
    """Four black slats 0.5 m over a 2 x 2 m floor of albedo 0.6, under a black 0.6 m emitter
    (radiance 1, facing down) 1 m up, at 60 texels/m. A floor point sees the emitter less
    what each slat hides of it: the slat's shadow on the emitter's plane, a rectangle, so its
    truth is rho * L * (F(emitter) - F(hidden rectangles)) by Lambert's formula. Over the
    texels in shadow, the light the floor gets is within 0.3 % of that: the 3x3 neighbour
    vote that lit a map texel's width of every shadow edge put 0.8 % there."""
    albedo, height = 0.6, 0.5
    emitter = [(-0.3, -0.3, 1.0), (-0.3, 0.3, 1.0), (0.3, 0.3, 1.0), (0.3, -0.3, 1.0)]
    slats, slat_y = [(-0.2, -0.15), (-0.1, -0.05), (0.0, 0.05), (0.1, 0.15)], (-0.2, 0.2)
    builder = SceneBuilder()
    builder.quad("floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], (albedo,) * 3)
    builder.quad("emitter", emitter, (0.0,) * 3, (1.0,) * 3, two_sided=False)
    for number, (x0, x1) in enumerate(slats):
        (y0, y1) = slat_y
        builder.quad(f"slat {number}", [(x0, y0, height), (x1, y0, height),
                                        (x1, y1, height), (x0, y1, height)], (0.0,) * 3)
    images, samples, progress = bake(builder.build(), ctx, settings=Settings(texel_density=60))
    assert progress.converged
    values, positions, normals = occupied(images, samples)
    floor = (np.abs(positions[:, 2]) < 1e-4) & (normals[:, 2] > 0.99)
    points, up = positions[floor], normals[floor]
    whole = analytic.polygon_form_factors(points, up, emitter)
    hidden = np.zeros(len(points))
    stretch = 1.0 / (1.0 - height)   # from a floor point through the slat onto the emitter
    for x0, x1 in slats:
        low = np.maximum(-0.3, points[:, :2] + (np.array([x0, slat_y[0]]) - points[:, :2]) * stretch)
        high = np.minimum(0.3, points[:, :2] + (np.array([x1, slat_y[1]]) - points[:, :2]) * stretch)
        overlap = np.all(high > low, axis=1)
        (x_low, y_low), (x_high, y_high) = low[overlap].T, high[overlap].T
        z = np.ones(overlap.sum())
        rectangles = np.stack([np.c_[x_low, y_low, z], np.c_[x_low, y_high, z],
                               np.c_[x_high, y_high, z], np.c_[x_high, y_low, z]], axis=1)
        hidden[overlap] += analytic.polygon_form_factors(points[overlap], up[overlap], rectangles)
    truth = albedo * (whole - hidden)
    shadow = hidden > 0.01 * whole
    assert shadow.sum() > 3000
    excess = (values[floor][shadow].mean(axis=1) - truth[shadow]).sum() / truth[shadow].sum()
    assert abs(excess) < 0.003, excess


def test_sealed_dark_room_stays_dark(ctx, gl_clean):
    """Two 1.5 x 1 x 1 m rooms of albedo 0.5 side by side, sealed from each other by a
    0.1 m wall; a point light in one: no light reaches the other, so its floor stays below
    0.1 % of the lit room's (its truth is zero)."""
    builder = SceneBuilder()
    white = (0.5,) * 3
    for name, x0, x1 in (("lit", -1.55, -0.05), ("dark", 0.05, 1.55)):
        builder.quad(f"{name}_floor", [(x0, 0, 0), (x1, 0, 0), (x1, 1, 0), (x0, 1, 0)], white)
        builder.quad(f"{name}_ceiling", [(x0, 0, 1), (x0, 1, 1), (x1, 1, 1), (x1, 0, 1)],
                     white)
        builder.quad(f"{name}_south", [(x0, 0, 0), (x0, 0, 1), (x1, 0, 1), (x1, 0, 0)], white)
        builder.quad(f"{name}_north", [(x0, 1, 0), (x1, 1, 0), (x1, 1, 1), (x0, 1, 1)], white)
        for x, facing_east in ((x0, True), (x1, False)):
            corners = [(x, 0, 0), (x, 1, 0), (x, 1, 1), (x, 0, 1)]
            builder.quad(f"{name}_wall_{x}", corners if facing_east else corners[::-1], white)
    scene = builder.build([PointLight(position=(-1.0, 0.4, 0.7), power=100.0)])
    values, positions, normals = occupied(*bake(scene, ctx)[:2])
    floor = (np.abs(positions[:, 2]) < 1e-4) & (normals[:, 2] > 0.99)
    lit = values[floor & (positions[:, 0] < 0)].mean()
    dark = values[floor & (positions[:, 0] > 0)].mean()
    assert lit > 0
    assert dark < 1e-3 * lit, dark / lit


def test_closed_room_of_albedo_0_99_is_the_furnace(ctx, gl_clean):
    """A closed 1.6 x 1.2 x 1 m room, every face emitting radiance 1 inwards and reflecting
    0.99: every texel's reflected radiance is rho / (1 - rho) = 99 (the furnace). Shooting
    alone gets there only after thousands of shots; a user stopping after 600 sees every
    texel within 1 % of it."""
    albedo = 0.99
    builder = SceneBuilder()
    x, y, z = 1.6, 1.2, 1.0
    faces = {   # counter-clockwise seen from outside
        "floor": [(0, 0, 0), (0, y, 0), (x, y, 0), (x, 0, 0)],
        "ceiling": [(0, 0, z), (x, 0, z), (x, y, z), (0, y, z)],
        "south": [(0, 0, 0), (x, 0, 0), (x, 0, z), (0, 0, z)],
        "north": [(0, y, 0), (0, y, z), (x, y, z), (x, y, 0)],
        "west": [(0, 0, 0), (0, 0, z), (0, y, z), (0, y, 0)],
        "east": [(x, 0, 0), (x, y, 0), (x, y, z), (x, 0, z)],
    }
    for name, corners in faces.items():
        builder.quad(name, corners[::-1], (albedo,) * 3, (1.0,) * 3, two_sided=False)
    images, samples, progress = bake(builder.build(), ctx, shots=600)
    assert not progress.finished and progress.unshot_fraction > 0.3
    values = occupied(images, samples)[0]
    relative = values / (albedo / (1 - albedo)) - 1.0
    assert np.abs(relative).max() < 0.01, (relative.min(), relative.max())


def test_lamp_a_fifth_of_a_millimetre_under_a_ceiling_lights_only_from_below(ctx, gl_clean):
    """A 130 x 105 mm lamp that reflects nothing (a pure Emission shader: radiance 1 from
    both faces) 0.2 mm under a ceiling tile of its own size (albedo 0.725), 1 m over a
    1.2 m floor of albedo 0.6. What the lamp's upper face sends into the gap can leave only
    along its edges: the share of the opposed rectangles' form factor that misses, times at
    most 1 + the tile's albedo, under 0.6 % of the lamp's lower face. So the floor is the
    single bounce rho * L * F of the lower face (Lambert's formula) within 1 %."""
    albedo, gap = 0.6, 0.0002
    lamp = [(0.0, 0.0, 1.0), (0.0, 0.105, 1.0), (0.13, 0.105, 1.0), (0.13, 0.0, 1.0)]
    tile = [(x, y, 1.0 + gap) for x, y, _ in lamp]
    escaping = 1.0 - analytic.parallel_squares_form_factor(0.13 / gap, 0.105 / gap)
    assert escaping * (1.0 + 0.725) < 0.006
    builder = SceneBuilder()
    builder.quad("floor", [(-0.5, -0.5, 0), (0.7, -0.5, 0), (0.7, 0.7, 0), (-0.5, 0.7, 0)],
                 (albedo,) * 3)
    builder.quad("tile", tile, (0.725,) * 3)
    builder.quad("lamp", lamp, (0.0,) * 3, (1.0,) * 3)
    images, samples, progress = bake(builder.build(), ctx)
    assert progress.converged
    values, positions, normals = occupied(images, samples)
    floor = (np.abs(positions[:, 2]) < 1e-4) & (normals[:, 2] > 0.99)
    truth = albedo * analytic.polygon_form_factors(positions[floor], normals[floor], lamp)
    relative = values[floor] / truth[:, None] - 1.0
    assert np.abs(relative).max() < 0.01, (relative.min(), relative.max())


@pytest.mark.parametrize("density", [5.0, 20.0, 60.0, 160.0, 400.0, 5000.0])
@pytest.mark.parametrize("size", [0.5, 4.0, 30.0])
def test_automatic_hemicube_resolution_follows_the_texel_density_and_its_floor(density, size):
    """By default (0) the hemicube face is the least power of two at which a face texel at
    the face's middle (2 / resolution radians) half the scene's diagonal away spans no more
    than a lightmap texel (1 / density) nor 1 / LEAST_MAP_DENSITY, within
    AUTOMATIC_HEMICUBE; a value set is kept."""
    assert Settings().hemicube_resolution == 0
    scene = (SceneBuilder().quad("floor", [(0, 0, 0), (size, 0, 0), (size, size, 0),
                                           (0, size, 0)])
             .build([PointLight(position=(0.0, 0.0, 1.0), power=1.0)]))
    distance = 0.5 * math.sqrt(2.0) * size
    resolution = hemicube_resolution(Settings(texel_density=density), scene)
    least, most = AUTOMATIC_HEMICUBE
    assert least <= resolution <= most and resolution & (resolution - 1) == 0
    finest_angle = min(1.0 / density, 1.0 / LEAST_MAP_DENSITY) / distance
    if resolution < most:      # resolves both (at most, the budget decides)
        assert finest_angle >= 2.0 / resolution
    if resolution > least:     # and half the resolution would not have
        assert finest_angle < 2.0 / (resolution // 2)
    assert hemicube_resolution(Settings(texel_density=density, hemicube_resolution=96),
                               scene) == 96
