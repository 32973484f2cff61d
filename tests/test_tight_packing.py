"""The lightmap layout: charts of whole texels claim no slivers of their neighbours, and the
GPU's tight packing of the charts comes back texel for texel to the atlas's layout."""
import numpy as np

from conftest import ROOT
from native import PointLight, Scene, Settings, Solver, build_atlas
from native.samples import SceneBuilder

DENSITY = 12.0   # texels per metre


def unit_quads(count, side=1.0, albedo=0.5):
    """``count`` separate squares of ``side`` metres in the plane z = 0 facing up, and an
    emitting one above them: one chart each."""
    builder = SceneBuilder()
    for index in range(count):
        x, y = 2.0 * side * (index % 10), 2.0 * side * (index // 10)
        builder.quad(f"square{index}", [(x, y, 0), (x + side, y, 0), (x + side, y + side, 0),
                                        (x, y + side, 0)], (albedo,) * 3)
    builder.quad("lamp", [(0, 0, 3), (0, side, 3), (side, side, 3), (side, 0, 3)], (albedo,) * 3,
                 (1.0,) * 3, two_sided=False)
    return builder.build()


def test_squares_of_whole_texels_cover_exactly_their_texels(ctx, gl_clean):
    """A 1 m square at 12 texels per metre is a chart of 12 x 12 whole texels. xatlas's
    single-float UVs put its edges a few millionths of a texel off, which claimed slivers of
    the next texels (216 texels of 1e-7 of a texel's area among 61 squares before)."""
    count = 60
    solver = Solver(unit_quads(count), Settings(texel_density=DENSITY, max_shots=1), ctx=ctx)
    try:
        samples = solver.texel_samples()
    finally:
        solver.release()
    areas = np.concatenate([page["area"][page["area"] > 0] for page in samples])
    assert len(areas) == (count + 1) * 144
    np.testing.assert_allclose(areas, 1.0 / DENSITY ** 2, rtol=1e-4)


def test_packed_charts_come_back_to_their_texels(ctx, gl_clean):
    """Many small charts (0.25 m squares, 3 x 3 texels each) leave most of the atlas to the
    gutters bilinear filtering needs; the GPU works on them packed tight. Every fully
    covered texel of the result's layout samples the point its atlas UVs map its centre to."""
    side = 0.25
    scene = unit_quads(200, side)
    solver = Solver(scene, Settings(texel_density=DENSITY, max_shots=1), ctx=ctx)
    try:
        samples = solver.texel_samples()
        atlas = solver.atlas
        gpu_width, gpu_height = solver.gpu_page_size
    finally:
        solver.release()
    width, height = solver.page_size
    assert gpu_width * gpu_height <= 0.5 * width * height
    checked = 0
    for triangle, page, corners in zip(atlas.triangles, atlas.page, atlas.texels):
        world = scene.vertices[scene.triangles[triangle]]
        low = np.floor(corners.min(axis=0)).astype(int)
        high = np.ceil(corners.max(axis=0)).astype(int)
        inverse = np.linalg.inv(np.stack([corners[1] - corners[0], corners[2] - corners[0]], 1))
        for y in range(low[1], high[1]):
            for x in range(low[0], high[0]):
                if samples[page]["coverage"][y, x] < 1.0 - 1e-4:
                    continue
                weights = inverse @ (np.array([x + 0.5, y + 0.5]) - corners[0])
                if weights.min() < 0.0 or weights.sum() > 1.0:
                    continue   # the centre lies in the chart's other triangle
                expected = world[0] + weights @ (world[1:] - world[0])
                np.testing.assert_allclose(samples[page]["position"][y, x], expected, atol=1e-5)
                checked += 1
    assert checked >= 200 * 4


def test_furnace_of_many_small_charts(ctx, gl_clean):
    """A closed unit cube of 6 x 16 separate 25 cm tiles, each emitting 1 and reflecting 0.5:
    every texel shows rho / (1 - rho) = 1 once converged, on the packed pages too."""
    albedo, tiles = 0.5, 4
    builder = SceneBuilder()
    step = 1.0 / tiles
    for axis in range(3):
        for far in (False, True):
            for i in range(tiles):
                for j in range(tiles):
                    square = np.array([(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]) * step
                    corners = np.insert(square, axis, float(far), axis=1)
                    if far == (axis != 1):   # wound to face the cube's inside
                        corners = corners[::-1]
                    builder.quad(f"tile{axis}{int(far)}{i}{j}", [tuple(c) for c in corners],
                                 (albedo,) * 3, (1.0,) * 3, two_sided=False)
    solver = Solver(builder.build(), Settings(texel_density=DENSITY, threshold=0.01), ctx=ctx)
    try:
        solver.run()
        images = solver.result()
        gpu_width, gpu_height = solver.gpu_page_size
        width, height = solver.page_size
    finally:
        solver.release()
    assert gpu_width * gpu_height < width * height
    values = np.concatenate([image[image[..., 3] == 1][:, :3] for image in images])
    assert len(values) == 6 * 144
    np.testing.assert_allclose(values, albedo / (1 - albedo), rtol=0.02)


def temple_column(*extra):
    """Column 01 exported from sample_blends/temple.blend (its faces numbered), a point light
    over it, and ``extra`` quads (name, corners) with faces of their own."""
    temple = Scene.load(ROOT / "bench" / "scenes" / "temple.npz")
    keep = np.nonzero(temple.object_index == temple.object_names.index("column_01"))[0]
    used, corners = np.unique(temple.triangles[keep], return_inverse=True)
    vertices, triangles = [temple.vertices[used]], [corners.reshape(-1, 3)]
    objects, faces = [np.zeros(len(keep), int)], [temple.polygon[keep]]
    names = ["column_01"]
    count, face = len(used), int(temple.polygon[keep].max()) + 1
    for index, (name, quad) in enumerate(extra, start=1):
        vertices.append(np.array(quad, dtype=float))
        triangles.append(count + np.array([[0, 1, 2], [0, 2, 3]]))
        objects.append(np.full(2, index))
        faces.append(np.full(2, face + index))
        names.append(name)
        count += 4
    return Scene(vertices=np.concatenate(vertices), triangles=np.concatenate(triangles),
                 object_index=np.concatenate(objects), object_names=names,
                 polygon=np.concatenate(faces),
                 lights=[PointLight(position=(0.0, 0.0, 20.0), power=1.0)])


def faces_cut(scene, atlas):
    """How many faces' triangles disagree on the texel corners they share."""
    row_of = np.full(len(scene.triangles), -1)
    row_of[atlas.triangles] = np.arange(len(atlas.triangles))
    cut = 0
    for face in np.unique(scene.polygon):
        corner_uv = {}
        for triangle in np.nonzero((scene.polygon == face) & (row_of >= 0))[0]:
            for vertex, uv in zip(scene.triangles[triangle], atlas.texels[row_of[triangle]]):
                corner_uv.setdefault(vertex, []).append(uv)
        cut += any(np.ptp(np.array(uvs), axis=0).max() > 1e-6 for uvs in corner_uv.values())
    return cut


def test_a_face_keeps_its_triangles_in_one_chart():
    """Blender keeps one lightmap UV per face corner, so the two triangles of a quad must
    agree on the UVs of the corners they share. xatlas charts triangles and cut 16 quads of
    each of the temple's fluted columns between their triangles (then Cycles baked those
    faces across charts up to 286 texels apart); the atlas moves such a face's triangles
    into one chart."""
    scene = temple_column()
    assert len(np.unique(scene.polygon)) > 400
    assert faces_cut(scene, build_atlas(scene, 2.0)) == 0


def test_faces_stay_whole_beside_a_face_too_small_to_chart():
    """A 0.1 micrometre square in a 2 km scene is left out of the atlas (xatlas puts it on
    no page); the column's faces are still kept whole, and the square is listed."""
    floor = [(-1000, -1000, -1), (1000, -1000, -1), (1000, 1000, -1), (-1000, 1000, -1)]
    speck = [(5, 5, 1), (5 + 1e-7, 5, 1), (5 + 1e-7, 5 + 1e-7, 1), (5, 5 + 1e-7, 1)]
    scene = temple_column(("floor", floor), ("speck", speck))
    atlas = build_atlas(scene, 2.0)
    assert sorted(atlas.unpacked) == list(np.nonzero(scene.object_index == 2)[0])
    assert faces_cut(scene, atlas) == 0
