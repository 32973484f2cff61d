"""The visibility cube drawn face by face (clusters culled per face) against the one
geometry-shader pass: the same maps, bit for bit, for shooters, point lights and the sun; the
per-face culling drops nothing that is drawn without it; and the bit a texel keeps for a
triangle seen from its back says what the triangle's corners say."""
from types import SimpleNamespace

import numpy as np
import pytest

import scenes

from native import Settings, SettingsError, Solver, preprocess, visibility
from native.gpu import using
from native.preprocess import VERTEX_LAYER_EXTENSION, draws_per_face
from native.samples import SceneBuilder
from native.state import View

# A texel's key (visibility_store.glsl): the surface number and the facing-away bit.
SURFACE_BITS = 0xFFF
FACES_AWAY_BIT = 0x1000
# A sun's view in views(): its faces are the bake's tiles (BakeState.sun_faces).
SUN = "sun"


def room():
    """A closed 2 m room of subdivided walls (the unit cube's faces, inward, the top emitting)
    with panels inside facing several ways: many clusters, triangles seen from both sides,
    and two that span the room."""
    builder = SceneBuilder()
    for name, corners in scenes.CUBE_FACES.items():
        emission = (1.0,) * 3 if name == "top" else (0.0,) * 3
        builder.quad(name, [tuple(2.0 * c for c in corner) for corner in corners],
                     emission=emission, two_sided=False, subdivisions=8)
    builder.quad("panel_up", [(0.4, 0.4, 0.7), (1.1, 0.4, 0.7), (1.1, 1.0, 0.7),
                              (0.4, 1.0, 0.7)], subdivisions=6)
    builder.quad("panel_tilted", [(1.2, 0.3, 0.3), (1.8, 0.5, 0.5), (1.6, 1.4, 1.6),
                                  (1.0, 1.2, 1.4)], subdivisions=6)
    builder.quad("panel_down", [(0.3, 1.3, 1.5), (0.3, 1.8, 1.5), (0.9, 1.8, 1.5),
                                (0.9, 1.3, 1.5)], subdivisions=6)
    # Two triangles across the room: each reaches many of a sun's tiles.
    builder.quad("panel_across", [(0.05, 0.05, 0.2), (1.95, 0.05, 0.25), (1.95, 1.95, 0.3),
                                  (0.05, 1.95, 0.25)])
    return builder.build()


def rotation(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q if np.linalg.det(q) > 0 else q * np.array([-1.0, 1.0, 1.0])


def views():
    """(view, faces, clip_below): shooters just above the floor and a wall and in the air, point
    lights, and the sun from a slant."""
    rng = np.random.default_rng(7)
    floor_frame = np.eye(3)
    wall_frame = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])   # n = +y
    shooters = [View(eye=np.array([0.7, 1.6, 1e-4]), frame=floor_frame, orthographic=False),
                View(eye=np.array([1.3, 1e-4, 0.9]), frame=wall_frame, orthographic=False)]
    shooters += [View(eye=rng.uniform(0.2, 1.8, 3), frame=rotation(rng), orthographic=False)
                 for _ in range(3)]
    lights = [View(eye=rng.uniform(0.2, 1.8, 3), frame=np.eye(3), orthographic=False)
              for _ in range(2)]
    sun = np.array([0.3, -0.4, -0.87])
    sun /= np.linalg.norm(sun)
    return ([(view, visibility.FRONT_FACES, True) for view in shooters]
            + [(view, visibility.ALL_FACES, False) for view in lights]
            + [(sun, SUN, False)])


def maps(solver, drawn_views):
    """The distance maps (layers, size, size, 2) the solver's visibility pass draws for each
    view, as raw bits."""
    from native.receivers import light_view
    from native.scene import SunLight
    state, vis = solver._bake.state, solver._bake.visibility
    found = []
    with using(solver.ctx):
        for view, faces, clip_below in drawn_views:
            if faces == SUN:
                faces = state.sun_faces
                view = light_view(SunLight(direction=tuple(view), strength=1.0),
                                  state.bounds)
            visibility.render(state, vis, view, faces=faces, clip_below=clip_below)
            found.append(np.frombuffer(vis.texture.read(), dtype=np.uint32).reshape(
                -1, state.map_size, state.map_size, 2)[:faces].copy())
    return found


def solver_for(ctx, draw):
    if draw == "PER_FACE" and VERTEX_LAYER_EXTENSION not in ctx.extensions:
        pytest.skip(f"the device lacks {VERTEX_LAYER_EXTENSION}")
    return Solver(room(), Settings(texel_density=8, hemicube_resolution=64, max_shots=1,
                                   visibility_draw=draw), ctx=ctx)


@pytest.mark.parametrize("sun_tiles", [2, 4])
def test_per_face_draws_give_the_geometry_shaders_maps_bit_for_bit(ctx, gl_clean, monkeypatch,
                                                                   sun_tiles):
    """Also with the sun's window in 4 x 4 tiles, as a level's (preprocess.sun_tiles): the
    geometry shader then routes a triangle to up to 16 faces."""
    monkeypatch.setattr(preprocess, "sun_tiles", lambda bounds, map_size, layers: sun_tiles)
    drawn = {}
    for draw in ("GEOMETRY_SHADER", "PER_FACE"):
        solver = solver_for(ctx, draw)
        try:
            assert solver._bake.state.per_face_visibility == (draw == "PER_FACE")
            assert solver._bake.state.sun_tiles == sun_tiles
            assert len(solver._bake.visibility.cluster_low) > 10
            drawn[draw] = maps(solver, views())
        finally:
            solver.release()
    for (view, faces, _), by_shader, by_face in zip(views(), *drawn.values()):
        covered = by_face[..., 0] < np.float32(visibility.DRAWN_DISTANCE).view(np.uint32)
        assert covered.any(), (faces, view)
        assert np.array_equal(by_shader, by_face), (faces, view)


def test_the_per_face_culling_drops_nothing_drawn_without_it(ctx, gl_clean, monkeypatch):
    solver = solver_for(ctx, "PER_FACE")
    try:
        culled = maps(solver, views())
        monkeypatch.setattr(visibility, "_reaching",
                            lambda vis, eye, normals: np.ones((len(vis.cluster_low),
                                                               len(normals)), dtype=bool))
        everything = maps(solver, views())
    finally:
        solver.release()
    for (view, faces, _), kept, full in zip(views(), culled, everything):
        assert np.array_equal(kept, full), (faces, view)


@pytest.mark.parametrize("draw", ["GEOMETRY_SHADER", "PER_FACE"])
def test_the_facing_away_bit_is_the_corners_orientation_seen_from_the_eye(ctx, gl_clean, draw):
    """Each surface of the room is flat: seen from an eye (perspective), it faces away where
    dot(cross(c1 - c0, c2 - c0), c0 - eye) > 0; seen along the sun's parallel rays, where its
    normal points along them."""
    solver = solver_for(ctx, draw)
    try:
        state = solver._bake.state
        corners = solver.scene.vertices[solver.scene.triangles]
        normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        surfaces = state.surfaces
        drawn_views = views()
        found = maps(solver, drawn_views)
    finally:
        solver.release()
    seen_away = set()
    for (view, faces, _), texels in zip(drawn_views, found):
        if faces == SUN:
            away = normals @ view > 0.0
        else:
            away = np.einsum("ij,ij->i", normals, corners[:, 0] - view.eye) > 0.0
        expected = {}
        for surface, triangle_away in zip(surfaces, away):
            expected.setdefault(int(surface), set()).add(bool(triangle_away))
        keys = texels[..., 1] & (SURFACE_BITS | FACES_AWAY_BIT)
        covered = texels[..., 0] < np.float32(visibility.DRAWN_DISTANCE).view(np.uint32)
        for key in np.unique(keys[covered]):
            surface, bit = int(key) & SURFACE_BITS, bool(key & FACES_AWAY_BIT)
            assert expected[surface] == {bit}, (faces, surface)
            seen_away.add(bit)
    assert seen_away == {False, True}


def test_per_face_asked_of_a_device_without_the_extension_says_so():
    device = SimpleNamespace(extensions=set(), info={"GL_RENDERER": "a GPU"})
    with pytest.raises(SettingsError, match=VERTEX_LAYER_EXTENSION):
        draws_per_face(device, Settings(visibility_draw="PER_FACE"))
    assert not draws_per_face(device, Settings())
