"""Glossy layers (native/lobes.py): where the light they reflect goes, and how much of it.

Truths: a near-mirror floor lights a wall as the lamp's mirror image below the floor does,
seen through the floor (reflectance times the image's irradiance, cos / d^2); a rough glossy
floor lights a wall standing on it as the lobe of each point of the floor, about the mirror
direction of the lamp there, sends (integrated over the floor); the lobe's
normalization against a Monte Carlo integral; Cycles' white-sky albedo of Blender's default
material in a furnace; the energy ledger; a matte scene keeps no incoming directions."""
import dataclasses
import math

import numpy as np
import pytest

from native import PointLight, Settings, Solver
from native import lobes
from native.samples import SceneBuilder
import scenes

LAMP = np.array([-1.5, 0.0, 1.0])
POWER = 400.0
GLOSS = 0.5                 # what the floor reflects, all of it in its glossy layer
WALL_ALBEDO = 0.01          # the wall's light bounces back to the floor a hundredth of it
WALL_X = 1.5


def mirror_floor_scene(roughness):
    """A 2 x 2 m floor (no diffuse part; GLOSS reflected by a glossy layer of ``roughness``)
    with a lamp above one side, and a wall 1.5 m beyond the floor's middle on the other."""
    scene = (SceneBuilder()
             .quad("floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], (0.0,) * 3,
                   subdivisions=4)
             .quad("wall", [(WALL_X, -1.5, 0), (WALL_X, -1.5, 3), (WALL_X, 1.5, 3),
                            (WALL_X, 1.5, 0)], (WALL_ALBEDO,) * 3, subdivisions=4)
             .build([PointLight(position=tuple(LAMP), power=POWER)]))
    floor = np.asarray(scene.object_names)[scene.object_index] == "floor"
    reflectance = np.where(floor[:, None], GLOSS, scene.albedo)
    return dataclasses.replace(scene, reflectance=reflectance,
                               roughness=np.where(floor, roughness, 1.0))


def image_irradiance(points):
    """The irradiance the lamp's mirror image (below the floor) gives wall points whose ray
    to it crosses the floor, times GLOSS; None where the ray misses the floor."""
    image = LAMP * np.array([1.0, 1.0, -1.0])
    d = points - image
    t = -image[2] / d[:, 2]                          # where the ray meets z = 0
    crossing = image + t[:, None] * d
    through = (np.abs(crossing[:, 0]) <= 1.0) & (np.abs(crossing[:, 1]) <= 1.0)
    distance2 = (d * d).sum(axis=1)
    cosine = d[:, 0] / np.sqrt(distance2)            # the wall faces -x
    intensity = POWER / (4.0 * math.pi)
    return np.where(through, GLOSS * intensity * cosine / distance2, np.nan)


def direct_irradiance(points):
    d = points - LAMP
    distance2 = (d * d).sum(axis=1)
    return POWER / (4.0 * math.pi) * (d[:, 0] / np.sqrt(distance2)) / distance2


def bake(scene, ctx, **settings):
    """The first page's lightmap and texel samples, and the ledger, of a bake to the end (the
    ambient term off: what the shots delivered)."""
    solver = Solver(scene, Settings(ambient=False, **settings), ctx=ctx)
    try:
        solver.run()
        image, samples, ledger = solver.result()[0], solver.texel_samples()[0], solver.ledger()
        assert ctx.error == "GL_NO_ERROR"
        return image, samples, ledger
    finally:
        solver.release()


def wall_reflected_light(ctx, roughness):
    """Per wall texel well inside the floor's mirror image: the irradiance Luxel's wall got
    from the floor (its lightmap less the lamp's direct light), the image's truth, and the
    wall's points."""
    image, samples, _ = bake(mirror_floor_scene(roughness), ctx, texel_density=12,
                             threshold=0.002)
    position = samples["position"][samples["occupied"]]
    irradiance = image[samples["occupied"]][:, 1] * math.pi / WALL_ALBEDO
    on_wall = np.abs(position[:, 0] - WALL_X) < 1e-4
    points = position[on_wall]
    truth = image_irradiance(points)
    # Away from the image's rim, which the lobe blurs: rays crossing the floor's middle.
    image_point = LAMP * np.array([1.0, 1.0, -1.0])
    crossing = image_point + (-image_point[2] / (points - image_point)[:, 2])[:, None] * (
        points - image_point)
    inside = (np.abs(crossing[:, 0]) < 0.7) & (np.abs(crossing[:, 1]) < 0.7)
    reflected = irradiance[on_wall] - direct_irradiance(points)
    return reflected[inside], truth[inside], points[inside]


def test_a_near_mirror_floor_lights_the_wall_as_the_lamps_mirror_image(ctx, gl_clean):
    """Roughness 0.15, whose lobe is the sharpest (lobes.SMOOTHEST): the wall's light from
    the floor within 5 % of GGX's lobe of that sharpest roughness in the mean, and within
    15 % on the middle 80 % of its texels; that lobe's tail spreads some of the mirror
    image's light beyond it, but most stays: the wall gets over 0.8 of the image's. As if
    diffuse (roughness 1) the floor sent it everywhere: the same texels got under a third of
    the image's."""
    got, image, points = wall_reflected_light(ctx, 0.15)
    assert len(got) >= 100
    truth = lobe_irradiance(points, lobes.SMOOTHEST, lamp=LAMP, floor_end=1.0)
    assert np.mean(got) / np.mean(truth) == pytest.approx(1.0, abs=0.05)
    low, high = np.percentile(got / truth, [10, 90])
    assert 0.85 < low and high < 1.15
    assert np.mean(got) / np.mean(image) > 0.8
    diffuse, _, _ = wall_reflected_light(ctx, 1.0)
    assert np.mean(diffuse) / np.mean(image) < 0.35


# A glossy floor beside a wall standing on it, lit by a lamp above the floor.
NEAR_LAMP = np.array([0.0, 0.0, 0.6])
NEAR_WALL_X = 0.6


def floor_and_wall_scene(roughness):
    """A 1.6 x 2 m floor reflecting GLOSS, all in a glossy layer of ``roughness``, with a
    wall standing on its edge at NEAR_WALL_X and a lamp 0.6 m above the floor, 0.6 m from the
    wall."""
    scene = (SceneBuilder()
             .quad("floor", [(-1, -1, 0), (NEAR_WALL_X, -1, 0), (NEAR_WALL_X, 1, 0),
                             (-1, 1, 0)], (0.0,) * 3, subdivisions=4)
             .quad("wall", [(NEAR_WALL_X, -1, 0), (NEAR_WALL_X, -1, 1.5),
                            (NEAR_WALL_X, 1, 1.5), (NEAR_WALL_X, 1, 0)], (WALL_ALBEDO,) * 3,
                   subdivisions=4)
             .build([PointLight(position=tuple(NEAR_LAMP), power=POWER)]))
    floor = np.asarray(scene.object_names)[scene.object_index] == "floor"
    return dataclasses.replace(scene, reflectance=np.where(floor[:, None], GLOSS, scene.albedo),
                               roughness=np.where(floor, roughness, 1.0))


def ggx_reflection(out, toward_light, alpha, normal_reflectance=None):
    """(N,) GGX's microfacet reflection towards ``out`` (N, 3) of light from
    ``toward_light`` (N, 3) off a surface facing +z, up to a factor for the light:
    D(h) G1(out) F(h . l) / cos(out), with the Schlick-free Fresnel term of a dielectric
    reflecting ``normal_reflectance`` at normal incidence (None: F = 1)."""
    half = out + toward_light
    half /= np.linalg.norm(half, axis=-1, keepdims=True)
    a2 = alpha * alpha
    cos_half = half[..., 2]
    distribution = a2 / (math.pi * (cos_half ** 2 * (a2 - 1.0) + 1.0) ** 2)
    cos_out = np.maximum(out[..., 2], 1e-9)
    tangent2 = (1.0 - cos_out ** 2) / cos_out ** 2
    masking = 2.0 / (1.0 + np.sqrt(1.0 + a2 * tangent2))
    fresnel = 1.0
    if normal_reflectance is not None:
        eta = (1.0 + math.sqrt(normal_reflectance)) / (1.0 - math.sqrt(normal_reflectance))
        c = (half * toward_light).sum(axis=-1)
        # Fresnel's equations, s and p polarized, averaged.
        cos_refracted = np.sqrt(1.0 - (1.0 - c * c) / eta ** 2)
        s_wave = ((c - eta * cos_refracted) / (c + eta * cos_refracted)) ** 2
        p_wave = ((cos_refracted - eta * c) / (cos_refracted + eta * c)) ** 2
        fresnel = (s_wave + p_wave) / 2.0
    return np.where(out[..., 2] > 0.0, distribution * masking * fresnel / cos_out, 0.0)


def hemisphere_directions(count, seed=1):
    rng = np.random.default_rng(seed)
    directions = rng.normal(size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    directions[:, 2] = np.abs(directions[:, 2])
    return directions


def ggx_power(toward_light, alpha, normal_reflectance=None, samples=400_000):
    """ggx_reflection()'s integral against the cosine over the hemisphere (Monte Carlo)."""
    out = hemisphere_directions(samples)
    values = ggx_reflection(out, np.broadcast_to(toward_light, out.shape), alpha,
                            normal_reflectance) * out[:, 2]
    return 2.0 * math.pi * values.mean()


def lobe_irradiance(points, roughness, lamp=NEAR_LAMP, floor_end=NEAR_WALL_X,
                    samples=(320, 400)):
    """The irradiance a glossy floor from x = -1 to ``floor_end`` (y from -1 to 1; that of
    floor_and_wall_scene() by default) lit by a lamp at ``lamp`` gives points of a wall
    facing -x: over a grid of floor points, the lamp's light reflected in GGX's lobe of
    alpha = roughness^2 for the lamp's direction at that point (without the Fresnel term:
    the scene has none; scaled to send what a diffuse surface would), cos cos / r^2."""
    alpha = roughness ** 2
    x = -1.0 + (np.arange(samples[0]) + 0.5) / samples[0] * (floor_end + 1.0)
    y = -1.0 + (np.arange(samples[1]) + 0.5) / samples[1] * 2.0
    grid_x, grid_y = np.meshgrid(x, y)
    floor = np.stack([grid_x.ravel(), grid_y.ravel(), np.zeros(grid_x.size)], axis=1)
    cell = (floor_end + 1.0) / samples[0] * 2.0 / samples[1]
    travel = floor - lamp
    distance2 = (travel * travel).sum(axis=1)
    travel /= np.sqrt(distance2)[:, None]
    irradiance = POWER / (4.0 * math.pi) * -travel[:, 2] / distance2
    # Each floor point's lobe is scaled by its light's slant, in 64 steps.
    slant = np.round(-travel[:, 2] * 64.0) / 64.0
    scales = {}
    for height in np.unique(slant):
        toward_light = np.array([math.sqrt(1.0 - height * height), 0.0, height])
        scales[height] = math.pi / ggx_power(toward_light, alpha, samples=200_000)
    radiance_scale = GLOSS * irradiance / math.pi * np.vectorize(scales.get)(slant)
    result = []
    for point in points:
        to_point = point - floor
        r2 = (to_point * to_point).sum(axis=1)
        to_point /= np.sqrt(r2)[:, None]
        lobe = ggx_reflection(to_point, -travel, alpha)
        # The floor faces +z, the wall -x.
        result.append((radiance_scale * lobe * to_point[:, 2] * to_point[:, 0] / r2).sum()
                      * cell)
    return np.array(result)


@pytest.mark.parametrize("roughness, mean_within, texel_within", [(0.5, 0.03, 0.10),
                                                                  (0.3, 0.05, None)])
def test_a_glossy_floor_lights_the_wall_standing_on_it_as_its_lobes_send(
        ctx, gl_clean, roughness, mean_within, texel_within):
    """The wall's light from the floor (its lightmap less the lamp's direct light), 0.15-0.8 m
    up its middle metre, against lobe_irradiance() (GGX at the roughness, or at the
    sharpest lobe's, lobes.SMOOTHEST): at Blender's default roughness 0.5 within 3 % in the
    mean and 10 % per texel, at the sharper 0.3 within 5 % in the mean. Each shooter's one
    lobe about the mirror of its texels' mean direction, seen from four points of its quad,
    gave 0.82 and 0.64 of a Phong lobe's light (texels down to 0.57): a floor block mirrors
    the lamp one way from its near side and another from its far side, and the wall in front
    of it gets most of its light from the near one. Not the wall's foot, within a texel and
    a half of the floor: there the lobe varies across even a quarter of a cell."""
    image, samples, _ = bake(floor_and_wall_scene(roughness), ctx, texel_density=12,
                             threshold=0.002)
    position = samples["position"][samples["occupied"]]
    irradiance = image[samples["occupied"]][:, 1] * math.pi / WALL_ALBEDO
    wall = ((np.abs(position[:, 0] - NEAR_WALL_X) < 1e-4) & (position[:, 2] > 0.15)
            & (position[:, 2] < 0.8) & (np.abs(position[:, 1]) < 0.5))
    points = position[wall]
    to_lamp = points - NEAR_LAMP
    direct = (POWER / (4.0 * math.pi) * (to_lamp[:, 0] / np.linalg.norm(to_lamp, axis=1))
              / (to_lamp * to_lamp).sum(axis=1))
    got = irradiance[wall] - direct
    truth = lobe_irradiance(points, max(roughness, lobes.SMOOTHEST))
    assert len(points) >= 60
    assert got.sum() / truth.sum() == pytest.approx(1.0, abs=mean_within)
    if texel_within is not None:
        np.testing.assert_allclose(got, truth, rtol=texel_within)


@pytest.mark.parametrize("height", [1.0, 0.6, 0.2])
@pytest.mark.parametrize("roughness, normal_reflectance", [(0.36, 1.0), (0.5, 0.04),
                                                           (0.9, 0.5)])
def test_lobe_sends_the_power_of_a_diffuse_shooter(height, roughness, normal_reflectance):
    """scale times the lobe, integrated against the cosine over the hemisphere, is pi (what a
    diffuse shooter of unit radiance sends per unit area): the lobe's integral against a
    Monte Carlo integral of GGX's reflection written out here, with Fresnel's equations."""
    axis = np.array([math.sqrt(1.0 - height * height), 0.0, height])
    toward_light = axis * np.array([-1.0, -1.0, 1.0])
    alpha = roughness ** 2
    integral = ggx_power(toward_light, alpha,
                         None if normal_reflectance >= 1.0 else normal_reflectance)
    assert lobes.lobe_integral(height, alpha, normal_reflectance) == pytest.approx(
        integral, rel=0.02)


def test_light_from_all_round_leaves_as_if_diffuse_and_from_one_direction_in_a_lobe():
    """The mixture's share from one direction: none for an even radiance (the irradiance-
    weighted mean direction two thirds of the normal, inwards), all for one direction."""
    normal = np.array([0.0, 0.0, 1.0])
    beta, _ = lobes.from_one_direction(-2.0 / 3.0 * normal, normal)
    assert beta == pytest.approx(0.0, abs=1e-6)
    one = np.array([0.6, 0.0, -0.8])
    beta, direction = lobes.from_one_direction(0.3 * one - 0.7 * 2.0 / 3.0 * normal, normal)
    assert beta == pytest.approx(0.3, abs=1e-6)
    np.testing.assert_allclose(direction, one, atol=1e-6)


def test_the_lobe_is_as_wide_as_the_roughness_of_the_texels_that_send_into_it():
    """A shooter of a glossy texel (roughness 0.5) and a matte one (roughness 1, no glossy
    layer): the lobe is the glossy texel's, GGX's alpha = roughness^2, not that of the two
    texels' mean roughness."""
    normal = np.array([0.0, 0.0, 1.0])
    slanting = np.array([0.6, 0.0, -0.8])
    reflection = lobes.reflect(
        normal, incoming=np.array([[*slanting, 1.0], [*slanting, 1.0]]),
        taken=np.full((2, 3), 0.5), reflectance=np.full((2, 3), 0.8),
        glossy=np.array([[0.04] * 3, [0.0] * 3]), roughness=np.array([0.5, 1.0]),
        fresnel=False)
    assert reflection.lobe.alpha == pytest.approx(0.5 ** 2)
    np.testing.assert_allclose(reflection.lobe.axis, [0.6, 0.0, 0.8], atol=1e-9)


def test_only_scenes_with_smooth_glossy_layers_keep_incoming_directions():
    assert lobes.needed(mirror_floor_scene(0.5))
    assert not lobes.needed(mirror_floor_scene(1.0))
    matte = mirror_floor_scene(0.5)
    assert not lobes.needed(dataclasses.replace(matte, reflectance=None))


# Cycles' white furnace of Blender's default Principled BSDF (base 0.8) by roughness
# (`bench/accuracy.py glossy-furnace`, BENCHMARKS.md "Glossy layers in a white furnace"): the
# DIFFUSE and GLOSSY colours at normal incidence, and the white-sky albedo of both. The Fresnel
# rise's damping was fitted at roughness 0.2, 0.5 and 1; 0.75 lies between. (At 0.35 the texels
# come out 0.977-0.998 of it: the sharper lobe, point-sampled; docs/benchmarks-log.md.)
DEFAULT_MATERIAL_FURNACE = [(0.5, 0.770, 0.0374, 0.8107), (0.75, 0.7784, 0.0267, 0.8067)]


@pytest.mark.parametrize("roughness, diffuse, glossy, white_sky", DEFAULT_MATERIAL_FURNACE)
def test_a_furnace_of_blenders_default_material_reflects_cycles_white_sky_albedo(
        ctx, gl_clean, roughness, diffuse, glossy, white_sky):
    """A closed cube emitting 1 inwards, every face Blender's default Principled BSDF of base
    0.8 (its DIFFUSE and GLOSSY colours and roughness) with its layers' Fresnel rise: the
    light all round it reflects is Cycles' white-sky albedo of that material, so the
    lightmap is diffuse / (1 - white sky), within 1.5 % (roughness 0.5 without the rise,
    0.807: 2 % under). The ledger balances with what the layers reflect beyond the
    material map."""
    scene = scenes.furnace_cube(diffuse)
    scene = dataclasses.replace(scene, reflectance=np.full_like(scene.albedo, diffuse + glossy),
                                roughness=np.full(len(scene.triangles), roughness),
                                glossy_fresnel=True)
    image, _, ledger = bake(scene, ctx, texel_density=16, shoot_level=1, threshold=0.002)
    values = image[image[..., 3] == 1][:, :3]
    np.testing.assert_allclose(values, diffuse / (1.0 - white_sky), rtol=0.015)
    assert ledger.imbalance() < 1e-4
