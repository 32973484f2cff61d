"""The solver against closed-form radiosity: form factors, the furnace, Blender's lights."""
from dataclasses import replace
import math

import numpy as np
import pytest

import analytic
import scenes
from texels import texel_lattice
from native import PROJECTIONS, PointLight, Settings, Solver, SpotLight, SunLight
from native.samples import SceneBuilder


@pytest.fixture(params=PROJECTIONS)
def projection(request):
    """Every analytic test runs with each visibility projection."""
    return request.param


def bake(scene, ctx, projection, **settings):
    # What the shots delivered: the ambient term (an estimate of what is still unshot) has
    # tests of its own.
    settings.setdefault("ambient", False)
    solver = Solver(scene, Settings(projection=projection, **settings), ctx=ctx)
    try:
        solver.run()
        return solver.result()[0], solver.texel_samples()[0], solver.progress
    finally:
        solver.release()


def receiver_texels(samples, z=0.0):
    """Occupied texels lying on the receiver plane z = 0 (the emitter is black)."""
    on_plane = samples["occupied"] & (np.abs(samples["position"][..., 2] - z) < 1e-5) \
        & (samples["normal"][..., 2] > 0.99)
    return np.nonzero(on_plane)


def test_texel_samples_lie_on_their_surface(ctx, gl_clean, projection):
    """Every occupied texel samples a point of the receiver square, partial ones included."""
    _, samples, _ = bake(scenes.parallel_squares((1.0, 1.0, 1.0)), ctx, projection, texel_density=16,
                         max_shots=1)
    rows, cols = receiver_texels(samples)
    position = samples["position"][rows, cols]
    assert len(rows) >= 16 * 16
    assert (position[:, :2] >= -1e-6).all() and (position[:, :2] <= 1 + 1e-6).all()
    # The areas of the receiver's texels add up to the square's area exactly.
    assert samples["area"][rows, cols].sum() == pytest.approx(1.0, rel=1e-4)


def test_parallel_squares_match_corner_formula(ctx, gl_clean, projection):
    radiance = np.array([1.0, 2.0, 0.5])
    albedo = 0.5
    image, samples, _ = bake(scenes.parallel_squares(radiance, albedo), ctx, projection, texel_density=16,
                             threshold=0.001, hemicube_resolution=64)
    rows, cols = receiver_texels(samples)
    expected_f = np.array([analytic.parallel_rectangle_form_factor(x, y, 0, 1, 0, 1, 1.0)
                           for x, y in samples["position"][rows, cols, :2]])
    measured = image[rows, cols, :3]
    expected = albedo * radiance * expected_f[:, None]
    # every texel, border texels included, within 3 %
    assert np.max(np.abs(measured / expected - 1)) < 0.03
    # the area mean within 1 % of rho E F(square -> square)
    area = samples["area"][rows, cols]
    mean = (measured * area[:, None]).sum(axis=0) / area.sum()
    truth = albedo * radiance * analytic.parallel_squares_form_factor(1, 1)
    np.testing.assert_allclose(mean, truth, rtol=0.01)


def test_perpendicular_squares_match_common_edge_formula(ctx, gl_clean, projection):
    radiance = np.array([3.0, 3.0, 3.0])
    albedo = 0.5
    image, samples, _ = bake(scenes.perpendicular_squares(radiance, albedo), ctx, projection,
                             texel_density=16, threshold=0.001, hemicube_resolution=64)
    rows, cols = receiver_texels(samples)
    area = samples["area"][rows, cols]
    measured = image[rows, cols, 0]
    mean = (measured * area).sum() / area.sum()
    truth = albedo * radiance[0] * analytic.perpendicular_form_factor(1.0, 1.0)
    assert mean == pytest.approx(truth, rel=0.02)

    # Texels next to the shared edge (within one texel) stay finite and close to Lambert's
    # formula at their sample points, where the form factor changes fastest.
    position = samples["position"][rows, cols]
    near_edge = position[:, 1] < 1.0 / 16
    assert near_edge.sum() >= 16
    wall = [(0, 0, 0), (0, 0, 1), (1, 0, 1), (1, 0, 0)]
    for point, value in zip(position[near_edge], measured[near_edge]):
        f = analytic.polygon_form_factor(point, np.array([0.0, 0.0, 1.0]), wall)
        assert np.isfinite(value)
        assert value == pytest.approx(albedo * radiance[0] * f, rel=0.10)


def test_an_emitter_across_the_receivers_plane_lights_it_by_the_part_in_front(ctx, gl_clean,
                                                                             projection):
    """A wall's top under a ceiling panel that reaches over the wall's plane: each shooter
    is clipped to the receiver's horizon, the part behind the wall sending nothing. The
    panel's texels are half a metre (it shoots from few, large ones); one straddles the
    plane, its middle in front."""
    radiance, albedo = 2.0, 0.5
    scene = (SceneBuilder()
             .quad("wall", [(0, 0, 0), (0, 1, 0), (0, 1, 0.8), (0, 0, 0.8)], (albedo,) * 3)
             .quad("panel", [(-0.15, 0, 1), (-0.15, 1, 1), (0.85, 1, 1), (0.85, 0, 1)],
                   (0.0,) * 3, (radiance,) * 3, two_sided=False)
             .build())
    scene = replace(scene, object_texel_scale=[1.0, 2.0 / 16.0])
    image, samples, _ = bake(scene, ctx, projection, texel_density=16, threshold=0.001,
                             hemicube_resolution=64)
    on_wall = samples["occupied"] & (np.abs(samples["position"][..., 0]) < 1e-5) \
        & (samples["normal"][..., 0] > 0.99) & (samples["coverage"] > 0.99)
    rows, cols = np.nonzero(on_wall)
    position = samples["position"][rows, cols]
    assert len(rows) >= 100
    in_front = [(0, 0, 1), (0, 1, 1), (0.85, 1, 1), (0.85, 0, 1)]
    truth = albedo * radiance * analytic.polygon_form_factors(
        position, np.array([[1.0, 0.0, 0.0]]), in_front)
    np.testing.assert_allclose(image[rows, cols, 0], truth, rtol=0.03)


@pytest.mark.parametrize("albedo", [0.5, 0.9])
def test_furnace_converges_to_closed_form(ctx, gl_clean, projection, albedo):
    """Closed cube, uniform emission 1 and albedo rho: reflected radiance rho / (1 - rho)."""
    image, samples, progress = bake(scenes.furnace_cube(albedo), ctx, projection, texel_density=8,
                                    shoot_level=2, threshold=0.002, hemicube_resolution=64)
    assert progress.converged
    occupied = image[..., 3] == 1
    assert occupied.sum() == 6 * 8 * 8
    expected = albedo / (1 - albedo)
    values = image[occupied][:, :3]
    assert np.max(np.abs(values / expected - 1)) < 0.01


def test_point_light_over_plane_is_cos_over_r_squared(ctx, gl_clean, projection):
    light = PointLight(position=(0.3, -0.2, 1.0), power=100.0, color=(1.0, 0.5, 0.25))
    albedo = 0.5
    image, samples, _ = bake(scenes.plane(2.0, albedo, [light]), ctx, projection, texel_density=12,
                             max_shots=1)
    rows, cols = receiver_texels(samples)
    d = np.asarray(light.position) - samples["position"][rows, cols]
    r2 = (d * d).sum(axis=1)
    cos = d[:, 2] / np.sqrt(r2)
    intensity = light.power * np.asarray(light.color) / (4 * math.pi)
    expected = albedo / math.pi * intensity[None, :] * (cos / r2)[:, None]
    np.testing.assert_allclose(image[rows, cols, :3], expected, rtol=0.02)


def test_spot_light_follows_blender_cone_and_blend(ctx, gl_clean, projection):
    spot = SpotLight(position=(0.0, 0.0, 1.0), direction=(0.0, 0.0, -1.0), power=50.0,
                     spot_size=math.radians(60), spot_blend=0.3)
    albedo = 0.5
    image, samples, _ = bake(scenes.plane(3.0, albedo, [spot]), ctx, projection, texel_density=10,
                             max_shots=1)
    rows, cols = receiver_texels(samples)
    d = samples["position"][rows, cols] - np.asarray(spot.position)
    r2 = (d * d).sum(axis=1)
    direction = d / np.sqrt(r2)[:, None]
    cos_axis = direction @ np.array([0.0, 0.0, -1.0])
    # Blender: smoothstep over a band of (1 - cos(size / 2)) * blend below the cone edge.
    cos_half = math.cos(math.radians(30))
    band = (1 - cos_half) * 0.3
    t = np.clip((cos_axis - cos_half) / band, 0, 1)
    mask = np.where(cos_axis > cos_half, t * t * (3 - 2 * t), 0.0)
    expected = albedo / math.pi * spot.power / (4 * math.pi) * mask * cos_axis / r2
    measured = image[rows, cols, 0]
    inside = mask > 0.999
    outside = cos_axis < cos_half - 0.02
    assert inside.sum() > 20 and outside.sum() > 20
    np.testing.assert_allclose(measured[inside], expected[inside], rtol=0.02)
    assert np.all(measured[outside] == 0.0)
    band_texels = (mask > 0.05) & (mask < 0.95)
    assert band_texels.sum() > 5
    np.testing.assert_allclose(measured[band_texels], expected[band_texels], rtol=0.15, atol=1e-3)


def test_sun_lights_by_cosine_and_casts_a_sharp_shadow(ctx, gl_clean, projection):
    """Sun tilted 30 degrees: lit texels get rho S cos / pi; a square blocker 0.5 m above the
    plane casts its shadow shifted by 0.5 tan(30 degrees)."""
    angle = math.radians(30)
    sun = SunLight(direction=(math.sin(angle), 0.0, -math.cos(angle)), strength=3.0)
    builder = SceneBuilder().quad("plane", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)],
                                  (0.5, 0.5, 0.5))
    builder.quad("blocker", [(-0.25, -0.25, 0.5), (-0.25, 0.25, 0.5), (0.25, 0.25, 0.5),
                             (0.25, -0.25, 0.5)], (0.5, 0.5, 0.5), receive=False)
    image, samples, _ = bake(builder.build([sun]), ctx, projection, texel_density=16, max_shots=1,
                             hemicube_resolution=256)
    rows, cols = receiver_texels(samples)
    position = samples["position"][rows, cols]
    measured = image[rows, cols, 0]
    shift = 0.5 * math.tan(angle)
    x, y = position[:, 0] - shift, position[:, 1]
    margin = 0.1
    in_shadow = (np.abs(x) < 0.25 - margin) & (np.abs(y) < 0.25 - margin)
    lit = (np.abs(x) > 0.25 + margin) | (np.abs(y) > 0.25 + margin)
    assert in_shadow.sum() > 4
    assert np.all(measured[in_shadow] == 0.0)
    np.testing.assert_allclose(measured[lit], 0.5 * 3.0 * math.cos(angle) / math.pi, rtol=0.01)


def test_partly_covered_texels_along_a_diagonal_edge_have_no_dark_rim(ctx, gl_clean, projection):
    """A right-triangle receiver: texels cut by its hypotenuse sample inside the triangle and
    match the corner formula like interior texels do."""
    from native import Scene
    vertices = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 1, 1), (1, 1, 1), (1, 0, 1)]
    triangles = [(0, 1, 2), (3, 4, 5), (3, 5, 6)]
    scene = Scene(vertices=np.array(vertices, float), triangles=np.array(triangles),
                  albedo=np.array([(0.5,) * 3, (0,) * 3, (0,) * 3]),
                  emission=np.array([(0,) * 3, (1,) * 3, (1,) * 3]),
                  emission_two_sided=np.array([True, False, False]),
                  object_index=np.array([0, 1, 1]), object_names=["triangle", "emitter"])
    image, samples, _ = bake(scene, ctx, projection, texel_density=20, threshold=0.001)
    rows, cols = receiver_texels(samples)
    position = samples["position"][rows, cols]
    area = samples["area"][rows, cols]
    assert area.sum() == pytest.approx(0.5, rel=1e-4)
    partial = area < 0.99 * area.max()
    assert partial.sum() >= 15
    assert (position[:, 0] + position[:, 1] <= 1 + 1e-5).all()
    expected = np.array([0.5 * analytic.parallel_rectangle_form_factor(x, y, 0, 1, 0, 1, 1.0)
                         for x, y in position[:, :2]])
    measured = image[rows, cols, 0]
    assert np.max(np.abs(measured[partial] / expected[partial] - 1)) < 0.03


def test_a_strong_light_casts_its_penumbra_from_its_texels(ctx, gl_clean, projection):
    """A 0.2 m light 1 m over a floor, half hidden by a black plate at 0.5 m whose edge runs
    under the light's centre. A floor point sees the part of the light its shadow line
    leaves, so it gets rho L F of that clipped square (Lambert). The light, 37 times a mean
    block's share of the power, shoots as parts (selection.FINEST_PARTS): every penumbra
    texel is within 10 % of the fully lit value (the cube's quarters 6.7 %, half a step of a
    4-step staircase; sixteenths 3.4 %; 20 % shot as 4 x 4 blocks; the hemisphere's quarters
    would be 13 %, its straight edges misplaced), and on average within 1 % (0.00 %; +1.6 %
    when the neighbour vote lit a map texel's width of each texel's shadow)."""
    albedo, half, light_z, plate_z = 0.5, 0.1, 1.0, 0.5
    light = [(-half, -half, light_z), (-half, half, light_z), (half, half, light_z),
             (half, -half, light_z)]   # faces the floor
    builder = SceneBuilder()
    builder.quad("floor", [(-.6, -.6, 0), (.6, -.6, 0), (.6, .6, 0), (-.6, .6, 0)], (albedo,) * 3)
    builder.quad("light", light, (0.0,) * 3, (1.0,) * 3, two_sided=False)
    builder.quad("plate", [(-1, -1, plate_z), (0, -1, plate_z), (0, 1, plate_z), (-1, 1, plate_z)],
                 (0.0,) * 3, receive=False)
    # The per-vertex projection draws the plate's edge straight: its remedy, subdivision,
    # tessellates the casters (the paper's Figure 5).
    remedy = {"subdivision": "ADAPTIVE"} if projection == "HEMISPHERE" else {}
    image, samples, _ = bake(builder.build(), ctx, projection, texel_density=40, threshold=0.0,
                             max_shots=100, **remedy)
    on_floor = samples["occupied"] & (np.abs(samples["position"][..., 2]) < 1e-6)
    position, value = samples["position"][on_floor], image[on_floor][:, 0]
    penumbra = (np.abs(position[:, 0]) < 0.09) & (np.abs(position[:, 1]) < 0.3)
    assert penumbra.sum() > 100
    up = np.array([0.0, 0.0, 1.0])
    # Seen from (x, y, 0), the plate's edge hides the light where x' < -x.
    expected = np.array([albedo * analytic.polygon_form_factor(
        p, up, [(max(-half, -p[0]), -half, light_z), (max(-half, -p[0]), half, light_z),
                (half, half, light_z), (half, -half, light_z)]) for p in position[penumbra]])
    lit = albedo * analytic.polygon_form_factor(np.array([0.2, 0.0, 0.0]), up, light)
    error = (value[penumbra] - expected) / lit
    assert abs(error.mean()) < 0.01
    assert np.abs(error).max() < 0.10


def test_two_sided_emitter_lights_both_sides_one_sided_only_its_front(ctx, gl_clean, projection):
    """A unit emitter half-way between two receivers 1 m apart: both get rho E F(0.5 m) when
    it emits from both faces (Blender's emission shader), only the one it faces otherwise.
    Albedos of 0.001 keep the reflected light under the threshold: only the emitter shoots."""
    albedo = 0.001
    for two_sided in (True, False):
        builder = SceneBuilder()
        builder.quad("floor", [(0, 0, -0.5), (1, 0, -0.5), (1, 1, -0.5), (0, 1, -0.5)],
                     (albedo,) * 3)
        builder.quad("ceiling", [(0, 0, 0.5), (0, 1, 0.5), (1, 1, 0.5), (1, 0, 0.5)],
                     (albedo,) * 3)
        builder.quad("emitter", [(0, 0, 0), (0, 1, 0), (1, 1, 0), (1, 0, 0)], (0.0,) * 3,
                     (2.0,) * 3, two_sided=two_sided)  # faces -z, towards the floor
        image, samples, _ = bake(builder.build(), ctx, projection, texel_density=12,
                                 threshold=0.001)
        for z, lit in ((-0.5, True), (0.5, two_sided)):
            on_plane = samples["occupied"] & (np.abs(samples["position"][..., 2] - z) < 1e-5)
            position = samples["position"][on_plane]
            measured = image[on_plane][:, 0]
            if not lit:
                assert np.all(measured == 0.0)
                continue
            expected = np.array([albedo * 2.0 * analytic.parallel_rectangle_form_factor(
                x, y, 0, 1, 0, 1, 0.5) for x, y in position[:, :2]])
            assert np.max(np.abs(measured / expected - 1)) < 0.03


@pytest.mark.parametrize("shoot_level", [0, 1, 2])
def test_an_open_shade_glowing_on_both_sides_does_not_light_its_own_outside(
        ctx, gl_clean, projection, shoot_level):
    """An open cone of 24 facets (a lamp shade: radius 0.22 m to 0.15 m over 0.3 m) glowing
    on both sides, and a black wall 0.6 m away: nothing can light the shade's outside. Shot
    from a texel whose surface bends across two facets, the inside's quad in the plane of the
    sample's facet through the facets' edge poked 1 cm through the shell over the next facet,
    and two outside texels took nearly all of the inside's exitance."""
    builder = SceneBuilder()
    builder.quad("wall", [(0.6, 1, -0.7), (0.6, -1, -0.7), (0.6, -1, 1), (0.6, 1, 1)],
                 (0.0,) * 3, two_sided=False)
    for corners in scenes.open_cone(0.22, 0.15, 0.3, facets=24):
        builder.quad("shade", corners, (0.5,) * 3, (1.0,) * 3, two_sided=True)
    image, samples, _ = bake(builder.build(), ctx, projection, texel_density=10,
                             threshold=0.001, shoot_level=shoot_level)
    shade = samples["occupied"] & (samples["position"][..., 0] < 0.5)
    assert shade.sum() >= 40
    # Radiance rho E / pi: E under a millionth of the exitance pi L.
    assert image[..., 0][shade].max() <= 0.5 * 1e-6


def test_a_shade_glowing_on_both_sides_lights_a_plate_as_traced_through_its_opening(
        ctx, gl_clean, projection):
    """The open shade above, 1.3 m up and glowing on both sides, and a plate 2.65 m off
    facing it, below: what the plate gets from the outside and, through the bottom opening,
    from the inside, against a ray-traced quadrature over the facets with the shade's own
    occlusion. Shot from one centre per facet, the inside (seen from the plate over part of
    its height) lit the plate 5 % too much."""
    shade = [[(x, y, z + 1.3) for x, y, z in corners]
             for corners in scenes.open_cone(0.22, 0.15, 0.3, facets=24)]
    builder = SceneBuilder().quad("plate", [(-0.15, 2.65, 0.0), (0.15, 2.65, 0.0),
                                            (0.15, 2.65, 0.35), (-0.15, 2.65, 0.35)],
                                  (0.5,) * 3)
    for corners in shade:
        builder.quad("shade", corners, (0.0,) * 3, (6.0,) * 3, two_sided=True)
    # The stereographic projection draws the facets next to the shooter with straight edges:
    # its remedy, as in the paper, is subdividing them.
    remedy = {"subdivision": "ADAPTIVE"} if projection == "HEMISPHERE" else {}
    image, samples, _ = bake(builder.build(), ctx, projection, texel_density=10,
                             threshold=0.001, **remedy)
    plate = samples["occupied"] & (samples["position"][..., 1] > 2.6)
    assert plate.sum() >= 9
    traced = 0.5 * analytic.traced_irradiance(samples["position"][plate],
                                              np.array([0.0, -1.0, 0.0]), shade, 6.0)
    assert image[..., 0][plate].mean() == pytest.approx(
        traced.mean(), rel=0.03 if projection == "HEMISPHERE" else 0.02)


def penumbra_scene():
    """A black plate at z = 0.5 covering x < 0.5 between a unit emitter at z = 1 and the unit
    receiver square at z = 0."""
    builder = SceneBuilder()
    builder.quad("receiver", scenes.RECEIVER, (0.5,) * 3)
    builder.quad("emitter", scenes.CEILING, (0.0,) * 3, (1.0,) * 3, two_sided=False)
    builder.quad("plate", [(-1, -1, 0.5), (-1, 2, 0.5), (0.5, 2, 0.5), (0.5, -1, 0.5)],
                 (0.0,) * 3, receive=False)
    return builder.build()


def penumbra_bracket(samples, density, albedo=0.5, slack_scale=1.0):
    """Per receiver texel: exact first-bounce value and the bracket it must lie in. From a
    receiver point at x0 the emitter is visible for x > 1 - x0 exactly; shooting from texel
    centres moves that edge by at most half an emitter texel (times ``slack_scale``)."""
    rows, cols = receiver_texels(samples)
    slack = slack_scale * (0.5 / density + 0.01)
    exact, low, high = [], [], []
    for x, y, _ in samples["position"][rows, cols]:
        edge = 1.0 - x
        for values, shift in ((exact, 0.0), (low, slack), (high, -slack)):
            values.append(albedo * analytic.parallel_rectangle_form_factor(
                x, y, min(max(edge + shift, 0), 1), 1, 0, 1, 1))
    return (rows, cols), np.array(exact), np.array(low), np.array(high)


def test_penumbra_of_an_occluding_plate_is_bracketed_by_exact_visibility(ctx, gl_clean,
                                                                        projection):
    """Every receiver texel lies within the bracket of exact visibility, and with cube faces
    or the nonlinear map within 0.5 % of it (RMS over the mean). The per-vertex
    hemisphere projection draws the plate's long edges straight where they are arcs (the
    paper's Figure 5); its remedy, subdivision, tessellates the casters: then it lies within
    a bracket twice as wide (measured: 74 of 256 texels outside the plain one by up to 0.9 %
    of the unshadowed value, none outside the doubled one)."""
    density = 16
    settings = dict(texel_density=density, shoot_level=0, hemicube_resolution=512,
                    threshold=0.0, max_shots=16 * 16)
    subdivision = dict(subdivision="ADAPTIVE", subdivision_level=2)
    image, samples, _ = bake(penumbra_scene(), ctx, projection, **settings,
                             **(subdivision if projection == "HEMISPHERE" else {}))
    texels, exact, low, high = penumbra_bracket(
        samples, density, slack_scale=2.0 if projection == "HEMISPHERE" else 1.0)
    value = image[texels][:, 0]
    assert len(value) == 16 * 16
    assert np.all((low - 1e-6 <= value) & (value <= high + 1e-6))
    if projection != "HEMISPHERE":
        # Each emitter texel's shadow edge, taken over the receiving texels' squares, adds up
        # to the penumbra: at their sample points the error was 5.4 % (cube) and 1.8 %.
        assert np.sqrt(np.mean((value - exact) ** 2)) < 0.005 * exact.mean()


def test_curved_surface_first_bounce_matches_lambert_on_every_facet(ctx, gl_clean, projection):
    """Inside a faceted sphere (a convex polyhedron: every facet sees every other unoccluded)
    the first bounce from the emitting cap at a point is rho * E * sum of Lambert's formula
    over the emitting facets; a texel shows its mean over the surface it covers (a lattice of
    points over its square). Albedo 1e-3 keeps later bounces below 0.1 %. Charts here fold
    across facets: a texel straddling a fold gathers over both facets' normals (at one
    sample's normal 84.7 % were within 3 %, the worst -32 %), but shoots from one plane, so a
    receiver within a texel of the fold loses the part of that quad behind its horizon
    (measured: median +0.5 %, 97.0 % of texels within 3 %, worst +16 %)."""
    albedo, radiance = 1e-3, 4.0
    scene = scenes.inward_sphere(albedo=albedo, radiance=radiance)
    solver = Solver(scene, Settings(projection=projection, texel_density=16, shoot_level=1,
                                    threshold=5e-4, hemicube_resolution=256, ambient=False),
                    ctx=ctx)
    try:
        solver.run()
        image, samples, progress = solver.result()[0], solver.texel_samples()[0], solver.progress
    finally:
        solver.release()
    assert progress.converged
    lattice = texel_lattice(solver.scene, solver.atlas, grid=4)
    at_points = sum(analytic.polygon_form_factors(lattice.points, lattice.normals,
                                                  scene.vertices[triangle])
                    for triangle in scene.triangles[scene.emission[:, 0] > 0])
    rows, cols = np.nonzero(samples["occupied"])
    form_factor = lattice.means(at_points, rows, cols)
    # Slivers of a corner that no lattice point falls on.
    on_lattice = np.isfinite(form_factor)
    assert on_lattice.mean() > 0.97
    rows, cols, form_factor = rows[on_lattice], cols[on_lattice], form_factor[on_lattice]
    error = image[rows, cols, 0] / (albedo * radiance * form_factor) - 1
    assert len(error) > 3000
    assert abs(np.median(error)) < 0.01
    assert np.mean(np.abs(error) < 0.03) > 0.95
    assert np.all(np.abs(error) < 0.25)


def test_uniform_sky_lights_an_open_plane_by_rho_times_radiance(ctx, gl_clean, projection):
    """A plane under a uniform sky of radiance L receives pi L: reflected rho L. A wall
    standing on it hides the part of the sky given by Lambert's form factor to the wall."""
    sky = np.array([0.4, 0.8, 1.2])
    builder = SceneBuilder().quad("plane", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)],
                                  (0.5, 0.5, 0.5))
    open_scene = builder.build(sky=sky)
    image, samples, _ = bake(open_scene, ctx, projection, texel_density=8, max_shots=300,
                             hemicube_resolution=64)
    rows, cols = receiver_texels(samples)
    np.testing.assert_allclose(image[rows, cols, :3], np.broadcast_to(0.5 * sky, (len(rows), 3)),
                               rtol=0.02)

    wall = [(0, -2, 0), (0, -2, 2), (0, 3, 2), (0, 3, 0)]
    walled = (SceneBuilder()
              .quad("plane", [(0, -1, 0), (2, -1, 0), (2, 1, 0), (0, 1, 0)], (0.5,) * 3)
              .quad("wall", wall, (0.0,) * 3, receive=False)
              .build(sky=sky))
    image, samples, _ = bake(walled, ctx, projection, texel_density=8, max_shots=300,
                             hemicube_resolution=256)
    rows, cols = receiver_texels(samples)
    points = samples["position"][rows, cols]
    away = points[:, 0] > 0.3     # clear of the shadow-map texels at the wall's foot
    hidden = analytic.polygon_form_factors(points[away], np.tile([0.0, 0.0, 1.0], (away.sum(), 1)),
                                           wall)
    expected = 0.5 * sky[None, :] * (1.0 - hidden)[:, None]
    assert hidden.min() > 0.05
    measured = image[rows, cols, :3][away]
    # 256 sun directions stand in for the sky: each texel within 5 %, the mean within 1 %.
    np.testing.assert_allclose(measured, expected, rtol=0.05)
    np.testing.assert_allclose(measured.mean(axis=0), expected.mean(axis=0), rtol=0.01)


def test_non_occluding_emitter_lights_without_casting_shadows(ctx, gl_clean, projection):
    """Blender area lights emit but block nothing: a second copy of the emitter, non-occluding,
    between the first emitter and the receiver changes nothing but adds its own light."""
    radiance = np.array([1.0, 1.0, 1.0])
    base = scenes.parallel_squares(radiance)
    reference, samples, _ = bake(base, ctx, projection, texel_density=8, threshold=0.001,
                                 hemicube_resolution=64, max_shots=2000)
    builder = (SceneBuilder()
               .quad("receiver", scenes.RECEIVER, (0.5,) * 3)
               .quad("emitter", scenes.CEILING, (0.0,) * 3, radiance, two_sided=False)
               .quad("area light", [(0, 0, 0.999), (0, 1, 0.999), (1, 1, 0.999), (1, 0, 0.999)],
                     (0.0,) * 3, radiance, two_sided=False, receive=False, occlude=False))
    scene = builder.build()
    doubled, samples2, _ = bake(scene, ctx, projection, texel_density=8, threshold=0.001,
                                hemicube_resolution=64, max_shots=2000)
    rows, cols = receiver_texels(samples)
    rows2, cols2 = receiver_texels(samples2)
    # The second emitter sits 1 mm lower: its form factor is within 0.3 % of the first's.
    np.testing.assert_allclose(doubled[rows2, cols2, :3].mean(axis=0),
                               2 * reference[rows, cols, :3].mean(axis=0), rtol=0.01)


@pytest.mark.parametrize("spot_at", [(0.0, 0.0), (0.35, 0.2), (-0.4, 0.1)])
@pytest.mark.parametrize("plate_x", [0.6, 1.4])
def test_a_hot_spot_lights_what_faces_it_by_its_own_radiance(ctx, gl_clean, projection, spot_at,
                                                             plate_x):
    """A spot light 0.3 m from a wall makes a hot spot on it, radiance rho_w I cos / (pi d^2)
    there; a plate 0.6 or 1.4 m from the wall, behind the spot's cone, faces it and gets the
    wall's light alone: rho_p / pi times the integral of L cos cos / r^2 over the wall (a
    600 x 600 quadrature). At 0.6 m, the wall's 40 cm blocks shot at their mean radiance gave
    the plate's texels up to 5.1 %, 4.8 % and 3.9 % too little (it faces the spot's bright
    middle); each block's quad in cells at their own radiance, 2.2 %, 1.6 % and 1.4 %; their
    parts on the slope between the cells' radiances, 1.4 %, 0.3 % and 0.5 %. At 1.4 m, where
    each cell took an even share of its block's form factor, 1.9 %, 1.9 % and 1.7 %; as
    their form factors from their middles share it, 0.7 %, 0.5 % and 0.5 %. The plate's
    albedo keeps its light back below 0.1 %."""
    wall_albedo, plate_albedo = 0.5, 0.05
    light = np.array([0.3, *spot_at])
    spot = SpotLight(position=tuple(light), power=100.0, direction=(-1.0, 0.0, 0.0),
                     spot_size=math.radians(150.0), spot_blend=0.0)
    scene = (SceneBuilder()
             .quad("wall", [(0, -1, -1), (0, 1, -1), (0, 1, 1), (0, -1, 1)], (wall_albedo,) * 3,
                   subdivisions=4)
             .quad("plate", [(plate_x, -0.1, -0.1), (plate_x, -0.1, 0.1), (plate_x, 0.1, 0.1),
                             (plate_x, 0.1, -0.1)], (plate_albedo,) * 3)
             .build(lights=[spot]))
    image, samples, _ = bake(scene, ctx, projection, texel_density=10, threshold=0.001)
    plate = samples["occupied"] & (np.abs(samples["position"][..., 0] - plate_x) < 1e-4)
    points = samples["position"][plate]
    steps = (np.arange(600) + 0.5) / 600 * 2.0 - 1.0
    y, z = np.meshgrid(steps, steps)
    wall = np.stack([np.zeros(y.size), y.ravel(), z.ravel()], axis=1)
    to_wall = wall - light
    distance = np.linalg.norm(to_wall, axis=1)
    in_cone = to_wall @ np.array([-1.0, 0.0, 0.0]) / distance > spot.cos_half_angle()
    radiance = (wall_albedo / math.pi * spot.intensity()[0] * -to_wall[:, 0] / distance ** 3
                * in_cone)
    to_point = points[:, None, :] - wall[None]                         # (P, W, 3)
    r2 = (to_point ** 2).sum(axis=2)
    cosines = to_point[..., 0] ** 2 / r2                              # both normals along x
    irradiance = (radiance * cosines / r2).sum(axis=1) * (2.0 / 600) ** 2
    truth = plate_albedo * irradiance / math.pi
    assert len(points) >= 4
    np.testing.assert_allclose(image[..., 0][plate], truth, rtol=0.015 if plate_x < 1.0 else 0.01)
