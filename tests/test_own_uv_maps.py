"""An object's own lightmap UV map (Scene.lightmap_uv): packed as it is, at the texel density,
beside Luxel's charts; the solver's furnace holds on it; overlaps are found from geometry."""
from dataclasses import replace

import numpy as np
import pytest

import scenes
from native import PointLight, SceneError, Settings, Solver
from native.atlas import build_atlas
from native.charting import overlapping_faces
from native.samples import SceneBuilder


def rectangle_uv(low, high):
    """The UVs of one SceneBuilder quad's two triangles, its corners at the rectangle's."""
    (u0, v0), (u1, v1) = low, high
    corners = np.array([(u0, v0), (u1, v0), (u1, v1), (u0, v1)])
    return corners[[[0, 1, 2], [0, 2, 3]]]


def test_overlaps_are_area_shared_by_two_faces_not_edges_they_meet_on():
    beside = np.concatenate([rectangle_uv((0, 0), (0.5, 1)), rectangle_uv((0.5, 0), (1, 1))])
    face = np.array([0, 0, 1, 1])
    assert not overlapping_faces(beside, face).any()
    shifted = np.concatenate([rectangle_uv((0, 0), (0.5, 1)), rectangle_uv((0.3, 0), (0.8, 1))])
    assert overlapping_faces(shifted, face).all()
    # Two faces meeting on a diagonal through the grid's centres, and a mirrored (clockwise)
    # copy of a face on top of it.
    diagonal = np.array([[(0, 0), (1, 0), (1, 1)], [(0, 0), (1, 1), (0, 1)]], dtype=float)
    assert not overlapping_faces(diagonal, np.array([0, 1])).any()
    mirrored = np.array([[(0, 0), (1, 0), (1, 1)], [(0, 0), (1, 1), (1, 0)]], dtype=float)
    assert overlapping_faces(mirrored, np.array([0, 1])).all()
    # A face's own triangles share an edge, never area; a third face inside the second.
    inside = np.concatenate([beside, rectangle_uv((0.6, 0.2), (0.7, 0.3))])
    found = overlapping_faces(inside, np.array([0, 0, 1, 1, 2, 2]))
    np.testing.assert_array_equal(found, [False, False, True, True, True, True])


def room_with_own_map():
    """A floor charted by Luxel and a box whose five faces come with a UV map of their own:
    rectangles of different shapes with gaps, inside [0, 1]."""
    builder = SceneBuilder()
    builder.quad("floor", [(-2, 0, -2), (-2, 0, 2), (2, 0, 2), (2, 0, -2)], (0.5,) * 3)
    builder.box("box", [(0, 1, 0), (1, 1, 0), (1, 1, 0.5), (0, 1, 0.5)], 0.0, (0.5,) * 3)
    scene = builder.build(lights=[PointLight((0.5, 3.0, 0.2), 100.0)])
    box = scene.object_index == scene.object_names.index("box")
    rectangles = [((0.0, 0.0), (0.4, 0.2)), ((0.5, 0.0), (0.9, 0.3)), ((0.0, 0.4), (0.2, 0.8)),
                  ((0.3, 0.4), (0.7, 0.6)), ((0.75, 0.4), (1.0, 1.0))]
    uv = np.full((len(scene.triangles), 3, 2), np.nan)
    uv[box] = np.concatenate([rectangle_uv(*r) for r in rectangles])
    return replace(scene, lightmap_uv=uv, receive_back=box), box


def test_own_map_is_one_scale_and_offset_at_the_density_beside_luxels_charts():
    scene, box = room_with_own_map()
    density = 24.0
    back_scene = scene.with_back_faces()
    atlas = build_atlas(back_scene, density, max_size=256, padding=2, align=4)
    rows = back_scene.object_index[atlas.triangles] == scene.object_names.index("box")
    front = rows & (back_scene.back_of[atlas.triangles] < 0)
    back = rows & (back_scene.back_of[atlas.triangles] >= 0)
    uv = back_scene.lightmap_uv[atlas.triangles]
    def area(c):
        edge, other = c[:, 1] - c[:, 0], c[:, 2] - c[:, 0]
        return 0.5 * np.abs(edge[:, 0] * other[:, 1] - edge[:, 1] * other[:, 0]).sum()
    # Texel density: the box's surface area times density squared, over its UV area.
    per_uv = density * np.sqrt(back_scene.triangle_area[atlas.triangles[front]].sum()
                               / area(uv[front]))
    for part in (front, back):
        texels, corners = atlas.texels[part].reshape(-1, 2), uv[part].reshape(-1, 2)
        offset = (texels - per_uv * corners).mean(axis=0)
        np.testing.assert_allclose(texels, per_uv * corners + offset, atol=1e-6)
    # The backs sit beside the fronts, and no two objects (nor fronts and backs) share area.
    assert atlas.texels[back][..., 0].min() >= atlas.texels[front][..., 0].max() + 2 - 1e-9
    assert len(set(atlas.page[rows])) == 1
    page = atlas.page == atlas.page[rows][0]
    owner = np.where(back, -1, back_scene.object_index[atlas.triangles])[page]
    side = max(atlas.width, atlas.height)
    assert not overlapping_faces(atlas.texels[page] / side, owner, resolution=4 * side).any()


def test_furnace_holds_on_an_own_uv_map(ctx, gl_clean):
    """Closed cube, uniform emission 1 and albedo rho: reflected radiance rho / (1 - rho)
    on every texel of a UV map laid out by hand (six faces of one object, a 3 x 2 grid)."""
    albedo = 0.5
    builder = SceneBuilder()
    for name, corners in scenes.CUBE_FACES.items():
        builder.quad("cube", corners, (albedo,) * 3, (1.0,) * 3, two_sided=False)
    scene = builder.build()
    uv = np.concatenate([rectangle_uv((0.3125 * k, 0.5 * j), (0.3125 * k + 0.25, 0.5 * j + 0.25))
                         for j in range(2) for k in range(3)])
    scene = replace(scene, lightmap_uv=uv)
    solver = Solver(scene, Settings(texel_density=8, shoot_level=2, threshold=0.002,
                                    hemicube_resolution=64, ambient=False), ctx=ctx)
    try:
        solver.run()
        image = solver.result()[0]
        assert solver.progress.converged
    finally:
        solver.release()
    occupied = image[..., 3] == 1
    assert occupied.sum() == 6 * 8 * 8
    values = image[occupied][:, :3]
    assert np.max(np.abs(values / (albedo / (1 - albedo)) - 1)) < 0.01
    assert ctx.error == 'GL_NO_ERROR'


def test_own_map_on_part_of_an_object_or_outside_the_square_is_refused():
    scene, box = room_with_own_map()
    partly = scene.lightmap_uv.copy()
    partly[np.nonzero(box)[0][0]] = np.nan
    with pytest.raises(SceneError, match="'box' has lightmap_uv on some of its triangles"):
        replace(scene, lightmap_uv=partly)
    outside = scene.lightmap_uv.copy()
    outside[box] += 0.5
    with pytest.raises(SceneError, match="object 'box'.*outside \\[0, 1\\]"):
        replace(scene, lightmap_uv=outside)
