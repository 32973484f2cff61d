"""Charting as meshes grow: back-face copies chart like their fronts, and a mesh charted in
pieces keeps every face whole, every triangle on texels and no texel shared by two charts."""
import numpy as np
import pytest

from native import PointLight, Scene
from native import charting
from native.atlas import build_atlas, clear_cache
from native.samples import SceneBuilder
from tests import scenes


def texel_area(texels):
    edges = texels[:, 1:] - texels[:, :1]
    return 0.5 * np.abs(edges[:, 0, 0] * edges[:, 1, 1] - edges[:, 0, 1] * edges[:, 1, 0])


def test_back_faces_chart_like_their_fronts():
    """A copy is its original's surface wound the other way: the same charts and texels.
    (Charted with the fronts as one mesh, the two sheets tangled into hundreds of charts.)"""
    vertices, triangles, normals = scenes.smooth_tube(0.3, 2.0, sides=32, rings=24)
    scene = Scene(vertices=vertices, triangles=triangles, normals=normals,
                  receive_back=np.ones(len(triangles), bool),
                  lights=[PointLight((1.0, 0.0, 0.0), 100.0)]).with_back_faces()
    clear_cache()
    atlas = build_atlas(scene, 20.0, max_size=512, padding=2)
    back = scene.back_of[atlas.triangles] >= 0
    assert back.sum() == (~back).sum() == len(triangles)
    front_charts, back_charts = (len(np.unique(atlas.chart[rows])) for rows in (~back, back))
    assert back_charts == front_charts
    np.testing.assert_allclose(texel_area(atlas.texels[back]).sum(),
                               texel_area(atlas.texels[~back]).sum(), rtol=0.02)


def quad_grid(cells):
    """A wavy sheet of ``cells`` x ``cells`` quads, each quad a face of two triangles."""
    xs = np.linspace(0.0, 2.0, cells + 1)
    x, y = np.meshgrid(xs, xs, indexing="ij")
    vertices = np.stack([x, y, 0.2 * np.sin(3 * x) * np.cos(2 * y)], axis=-1).reshape(-1, 3)
    corner = (np.arange(cells)[:, None] * (cells + 1) + np.arange(cells)[None, :]).ravel()
    a, b, c, d = corner, corner + cells + 1, corner + cells + 2, corner + 1
    triangles = np.stack([np.stack([a, b, c], 1), np.stack([a, c, d], 1)], 1).reshape(-1, 3)
    polygon = np.repeat(np.arange(len(corner)), 2)
    return Scene(vertices=vertices, triangles=triangles, polygon=polygon,
                 lights=[PointLight((1.0, 1.0, 1.0), 100.0)])


@pytest.mark.parametrize("piece", [50, 100_000])
def test_pieces_keep_faces_whole_and_charts_apart(monkeypatch, piece):
    monkeypatch.setattr(charting, "XATLAS_PIECE_TRIANGLES", piece)
    scene = quad_grid(24)
    clear_cache()
    atlas = build_atlas(scene, 30.0, max_size=1024, padding=2)
    assert len(atlas.triangles) == len(scene.triangles) and len(atlas.unpacked) == 0
    # Each face's two triangles lie in one chart.
    chart_of = np.full(len(scene.triangles), -1)
    chart_of[atlas.triangles] = atlas.chart
    assert (chart_of[0::2] == chart_of[1::2]).all()
    if piece == 50:
        assert len(np.unique(atlas.chart)) > 1
    # Texels follow surface area: density^2 times the area, up to the charts' stretch.
    np.testing.assert_allclose(texel_area(atlas.texels).sum(),
                               30.0 ** 2 * scene.triangle_area.sum(), rtol=0.1)
    # No texel is held by two charts (texel boxes of each chart's triangles, less a margin).
    owner = np.full((atlas.height + 1, atlas.width + 1), -1)
    for chart in np.unique(atlas.chart):
        held = np.zeros_like(owner, dtype=bool)
        for corners in atlas.texels[atlas.chart == chart]:
            x0, y0 = np.floor(corners.min(axis=0) + 1e-6).astype(int)
            x1, y1 = np.ceil(corners.max(axis=0) - 1e-6).astype(int)
            held[y0:y1, x0:x1] = True
        assert (owner[held] == -1).all()
        owner[held] = chart


def two_boxes(shift_second=0.0):
    """Two boxes of one shape, 3 m apart, each an object and a layout of its own (as moved
    copies or linked duplicates with modifiers are exported)."""
    builder = SceneBuilder()
    for name, x in (("first", 0.0), ("second", 3.0)):
        builder.box(name, [(x, 0.4, 0), (x + 0.6, 0.4, 0), (x + 0.6, 0.4, 0.5), (x, 0.4, 0.5)],
                    0.0, (0.5,) * 3)
    scene = builder.build(lights=[PointLight((1.5, 2.0, 0.0), 100.0)])
    second = scene.object_index == scene.object_names.index("second")
    scene.vertices[np.unique(scene.triangles[second][:1])] += [0.0, 0.0, shift_second]
    return scene


def test_meshes_of_one_shape_are_charted_once_and_a_changed_one_alone_again(monkeypatch):
    generated = []
    monkeypatch.setattr(charting, "_generate",
                        lambda atlas, *options: generated.append(atlas) or atlas.generate(
                            *options))
    clear_cache()
    scene = two_boxes()
    atlas = build_atlas(scene, 20.0, max_size=256, padding=2)
    assert len(generated) == 1
    first, second = (scene.object_index[atlas.triangles] == scene.object_names.index(name)
                      for name in ("first", "second"))
    shift = atlas.texels[second] - atlas.texels[first]
    np.testing.assert_allclose(shift, shift[:1, :1].repeat(len(shift), 0).repeat(3, 1))
    np.testing.assert_allclose(shift, np.round(shift))
    # One corner of the second box moved: it alone is charted again.
    moved = build_atlas(two_boxes(shift_second=0.05), 20.0, max_size=256, padding=2)
    assert len(generated) == 2
    np.testing.assert_array_equal(moved.texels[first] - moved.object_origin[scene.object_names.index("first")],
                                  atlas.texels[first] - atlas.object_origin[scene.object_names.index("first")])
