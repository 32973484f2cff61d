"""The error measured where a renderer looks a lightmap up (native/evaluation/surface_error.py):
points spread by area off the charts' borders, bilinear lookups, against closed forms."""
import math

import numpy as np
import pytest

import scenes
from native import PointLight, Settings, Solver
from native.evaluation.surface_error import look_up, surface_error, surface_points


def distance_to_segment(points, a, b):
    along = np.clip(((points - a) @ (b - a)) / ((b - a) @ (b - a)), 0.0, 1.0)
    return np.linalg.norm(points - (a + along[:, None] * (b - a)), axis=1)


def test_points_lie_inset_on_their_triangle_spread_by_the_inset_area():
    # A right triangle with legs 1 (inradius 1 / (2 + sqrt 2)) and one with legs 2 and 1, on
    # pages 0 and 1; an inset of 0.1 keeps (1 - 0.1 / r)^2 of each one's area.
    corners = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]],
                        [[0, 0, 1], [2, 0, 1], [0, 1, 1]]], dtype=np.float64)
    texels = corners[:, :, :2] * 10.0
    inset, count = 0.1, 20000
    points = surface_points(corners, texels, pages=[0, 1], count=count, inset=inset, seed=3)
    for index, (a, b, c) in enumerate(corners):
        mine = points.triangle == index
        assert (points.page[mine] == index).all()
        position = points.position[mine]
        nearest = np.min([distance_to_segment(position, p, q)
                          for p, q in ((a, b), (b, c), (c, a))], axis=0)
        assert nearest.min() >= inset - 1e-9
        # Inside the triangle: its barycentric weights are all positive.
        edge_1, edge_2 = b - a, c - a
        d = position - a
        matrix = np.array([[edge_1 @ edge_1, edge_1 @ edge_2], [edge_1 @ edge_2, edge_2 @ edge_2]])
        s, t = np.linalg.solve(matrix, np.stack([d @ edge_1, d @ edge_2])).reshape(2, -1)
        assert (s > 0).all() and (t > 0).all() and (s + t < 1).all()
        # The lightmap position follows the same barycentrics (texels are the corners x 10).
        np.testing.assert_allclose(points.texel[mine], position[:, :2] * 10.0, atol=1e-9)
    kept = []
    for legs in ((1.0, 1.0), (2.0, 1.0)):
        area = legs[0] * legs[1] / 2
        radius = 2 * area / (legs[0] + legs[1] + math.hypot(*legs))
        kept.append(area * (1 - inset / radius) ** 2)
    share = kept[0] / sum(kept)
    sigma = math.sqrt(share * (1 - share) / count)
    assert abs(np.mean(points.triangle == 0) - share) < 4 * sigma


def test_a_triangle_narrower_than_the_inset_holds_no_point():
    corners = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]],
                        [[0, 0, 0], [5, 0, 0], [0, 0.05, 0]]], dtype=np.float64)
    points = surface_points(corners, corners[:, :, :2], pages=[0, 0], count=500, inset=0.05)
    assert (points.triangle == 0).all()
    with pytest.raises(ValueError, match="inset"):
        surface_points(corners[1:], corners[1:, :, :2], pages=[0], count=10, inset=0.05)


def strip_of_facets(width=1.0, height=0.2, facets=20):
    """A width x height rectangle in z = 0 cut into ``facets`` upright strips of two
    triangles each, every triangle narrower than the tests' inset allows on its own."""
    xs = np.linspace(0.0, width, facets + 1)
    corners = []
    for left, right in zip(xs[:-1], xs[1:]):
        corners.append([[left, 0, 0], [right, 0, 0], [right, height, 0]])
        corners.append([[left, 0, 0], [right, height, 0], [left, height, 0]])
    return np.array(corners, dtype=np.float64)


def test_facets_narrower_than_the_inset_inside_one_chart_hold_points_off_its_border():
    """A curved surface's facets (a column's, a cable's) are narrower than twice the inset,
    but filtering mixes in no padding between them: only the chart's border keeps points
    away. Here one chart of 20 strips 5 cm wide, each of two triangles whose inradius
    (2.2 cm) is under the 3 cm inset: the points fill the rectangle 3 cm inside its outline
    evenly, and none lies nearer."""
    inset, count = 0.03, 20000
    corners = strip_of_facets()
    points = surface_points(corners, corners[:, :, :2] * 100.0, pages=np.zeros(len(corners)),
                            count=count, inset=inset, seed=4)
    assert len(points.page) == count
    x, y = points.position[:, 0], points.position[:, 1]
    assert x.min() >= inset - 1e-9 and x.max() <= 1.0 - inset + 1e-9
    assert y.min() >= inset - 1e-9 and y.max() <= 0.2 - inset + 1e-9
    np.testing.assert_allclose(points.texel, points.position[:, :2] * 100.0, atol=1e-9)
    # Even over the kept rectangle: the share left of its middle, and of each facet inside.
    sigma = math.sqrt(0.25 / count)
    assert abs(np.mean(x < 0.5) - 0.5) < 4 * sigma
    facet = np.floor(x / 0.05).astype(int)
    share = 0.05 / (1.0 - 2 * inset)
    for index in range(1, 19):
        assert abs(np.mean(facet == index) - share) < 4 * math.sqrt(share * (1 - share) / count)


def test_a_seam_between_two_charts_keeps_points_away_as_a_border_does():
    """The same facets, the right half on texels of its own (a second chart, or a second
    page): the shared edge at x = 0.5 is a seam, where a lookup mixes in padding."""
    inset = 0.03
    corners = strip_of_facets()
    right = corners[:, :, 0].mean(axis=1) > 0.5
    texels = corners[:, :, :2] * 100.0 + np.where(right, 60.0, 0.0)[:, None, None]
    seam = surface_points(corners, texels, pages=np.zeros(len(corners)), count=5000,
                          inset=inset, seed=5)
    paged = surface_points(corners, corners[:, :, :2] * 100.0, pages=right.astype(int),
                           count=5000, inset=inset, seed=5)
    for points in (seam, paged):
        assert np.abs(points.position[:, 0] - 0.5).min() >= inset - 1e-9
        assert abs(np.mean(points.position[:, 0] < 0.5) - 0.5) < 4 * math.sqrt(0.25 / 5000)


def test_bilinear_lookup_of_an_affine_page_is_the_affine_function():
    """Filtering between texel centres reproduces a map affine in the texel position, as a
    GPU's bilinear sampler does: the centre of texel (i, j) is (i + 0.5, j + 0.5)."""
    height, width = 12, 20
    x, y = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    colour = np.array([[0.2, 1.0, 0.05], [0.03, 0.5, 0.0], [0.01, 0.0, 0.4]])  # 1, x, y
    page = np.stack([np.ones_like(x), x, y], axis=-1) @ colour
    page = np.concatenate([page, np.ones((height, width, 1))], axis=-1)
    corners = np.array([[[1, 1, 0], [19, 1, 0], [1, 11, 0]],
                        [[19, 11, 0], [1, 11, 0], [19, 1, 0]]], dtype=np.float64)
    points = surface_points(corners, corners[:, :, :2], pages=[0, 0], count=2000, inset=0.5)
    values = look_up([page], points)
    expected = np.column_stack([np.ones(len(values)), points.texel]) @ colour
    np.testing.assert_allclose(values, expected, rtol=1e-12, atol=1e-12)
    assert surface_error(values, expected).rms < 1e-12
    error = surface_error(values * 1.1, values)
    assert error.relative_rms == pytest.approx(0.1)


def test_a_lamp_over_a_floor_looked_up_on_its_surface_is_cos_over_r_squared(ctx, gl_clean):
    """A point lamp's direct light on a plane, read back through each point's lightmap lookup,
    against the closed form at the point (albedo / pi x I cos / r^2): the lookups land where
    the atlas put the surface."""
    light = PointLight(position=(0.3, -0.2, 1.0), power=100.0, color=(1.0, 0.5, 0.25))
    albedo = 0.5
    solver = Solver(scenes.plane(2.0, albedo, [light]),
                    Settings(texel_density=12, max_shots=1, ambient=False), ctx=ctx)
    try:
        solver.run()
        pages = solver.result()
        atlas, scene = solver.atlas, solver.scene
        corners = scene.vertices[scene.triangles[atlas.triangles]]
        points = surface_points(corners, atlas.texels, atlas.page, count=4000, inset=0.02)
    finally:
        solver.release()
    d = np.asarray(light.position) - points.position
    r2 = (d * d).sum(axis=1)
    intensity = light.power * np.asarray(light.color) / (4 * math.pi)
    expected = albedo / math.pi * intensity[None, :] * (d[:, 2] / np.sqrt(r2) / r2)[:, None]
    assert surface_error(look_up(pages, points), expected).relative_rms < 0.01
