"""The rasterization's texel clip (texel_clip.glsl): each texel's covered share of every
triangle, as the area pass (raster_area.frag) sums it, against the exact overlap of the
triangle and the texel's square clipped on the CPU (plane_polygons, Sutherland-Hodgman)."""
import math

import moderngl
import numpy as np
import pytest

from native.gpu import GLObjects, buffer_content, render_state, using
from native.plane_polygons import area, clipped
from native.preprocess import RASTER_LAYOUT

PAGE = 32   # texels a side


def triangles_of(kind, rng):
    """(N, 3, 2) texel coordinates: small and large triangles anywhere, corners on the texel
    grid or halfway (edges along texel edges), and slivers."""
    count = 400
    middles = rng.uniform(4.0, PAGE - 4.0, (count, 1, 2))
    if kind == "small":
        return middles + rng.normal(0.0, 0.4, (count, 3, 2))
    if kind == "large":
        return middles[:40] + rng.normal(0.0, 4.0, (40, 3, 2))
    if kind == "on the grid":
        return np.round(2.0 * (middles + rng.normal(0.0, 1.5, (count, 3, 2)))) / 2.0
    # Slivers: the third corner a hair off the line through the first two.
    start, step = middles[:, 0], rng.normal(0.0, 3.0, (count, 2))
    off_line = 1e-3 * np.stack([-step[:, 1], step[:, 0]], axis=1)
    return np.stack([start, start + step, start + 0.5 * step + off_line], axis=1)


def exact_shares(triangles):
    """(PAGE, PAGE) sum over the triangles of the share of each texel's square they cover."""
    shares = np.zeros((PAGE, PAGE))
    for triangle in triangles:
        corners = [complex(x, y) for x, y in triangle]
        low = np.clip(np.floor(triangle.min(axis=0)).astype(int), 0, PAGE - 1)
        high = np.clip(np.floor(triangle.max(axis=0)).astype(int), 0, PAGE - 1)
        for y in range(low[1], high[1] + 1):
            for x in range(low[0], high[0] + 1):
                square = [complex(x, y), complex(x + 1, y), complex(x + 1, y + 1),
                          complex(x, y + 1)]
                part = clipped(corners, square)
                shares[y, x] += area(part) if len(part) >= 3 else 0.0
    return shares


def drawn_shares(ctx, triangles):
    """The area pass's sum per texel, the triangles laid flat in world space at one metre a
    texel, so that a texel's area is its covered share."""
    count = len(triangles)
    vertex_data = np.zeros((count, 3, sum(size for _, size in RASTER_LAYOUT)), np.float32)
    vertex_data[..., 0:2] = triangles                 # in_texel
    vertex_data[..., 2:4] = triangles                 # in_position's x and y (z = 0)
    vertex_data[..., 7] = 1.0                         # in_normal = +z
    with using(ctx):
        gl = GLObjects(ctx)
        try:
            program = gl.program("raster.vert", "raster_area.frag", "raster.geom")
            program["u_atlas_size"] = (float(PAGE), float(PAGE))
            vbo = gl.buffer(vertex_data.tobytes())
            vao = gl.vertex_array(program, [buffer_content(program, vbo, RASTER_LAYOUT)])
            sums, normal_sums = gl.texture((PAGE, PAGE), 4), gl.texture((PAGE, PAGE), 4)
            target = gl.framebuffer([sums, normal_sums])
            target.use()
            with render_state(ctx, blend=moderngl.FUNC_ADD):
                target.clear(0.0, 0.0, 0.0, 0.0)
                vao.render(moderngl.TRIANGLES)
            area_sum, covered = (np.frombuffer(texture.read(), np.float32)
                                 .reshape(PAGE, PAGE, 4)[..., 3].astype(np.float64)
                                 for texture in (sums, normal_sums))
            return area_sum, covered
        finally:
            gl.release()


@pytest.mark.parametrize("kind", ["small", "large", "on the grid", "slivers"])
def test_each_texel_gets_the_exact_share_of_each_triangle_it_covers(ctx, gl_clean, kind):
    triangles = triangles_of(kind, np.random.default_rng(7))
    # Triangles off the page are not what this measures.
    triangles = triangles[(triangles.min(axis=(1, 2)) >= 0.0)
                          & (triangles.max(axis=(1, 2)) <= PAGE)]
    expected = exact_shares(triangles)
    area_sum, covered = drawn_shares(ctx, triangles)
    # Per texel, within single floats' rounding of the sums (up to a few hundred parts).
    parts = max(1, math.ceil(len(triangles) / 100))
    np.testing.assert_allclose(area_sum, expected, atol=2e-6 * parts, rtol=1e-5)
    np.testing.assert_allclose(covered, expected, atol=2e-6 * parts, rtol=1e-5)
    edges = np.roll(triangles, -1, axis=1) - triangles
    total = 0.5 * np.abs(np.cross(edges[:, 0], -edges[:, 2])).sum()
    assert area_sum.sum() == pytest.approx(total, rel=1e-5, abs=1e-6)
