"""Scenes with closed-form answers, built through the solver API."""
import math

import numpy as np

from native.samples import SceneBuilder

RECEIVER = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]          # z = 0, facing +z
CEILING = [(0, 0, 1), (0, 1, 1), (1, 1, 1), (1, 0, 1)]           # z = 1, facing -z
WALL = [(0, 0, 0), (0, 0, 1), (1, 0, 1), (1, 0, 0)]              # y = 0, facing +y


def parallel_squares(radiance, albedo=0.5):
    """Unit receiver under a black unit emitter at distance 1."""
    return (SceneBuilder()
            .quad("receiver", RECEIVER, (albedo,) * 3)
            .quad("emitter", CEILING, (0.0,) * 3, radiance, two_sided=False)
            .build())


def perpendicular_squares(radiance, albedo=0.5):
    """Unit receiver on the floor and a black unit emitter standing on their common edge."""
    return (SceneBuilder()
            .quad("receiver", RECEIVER, (albedo,) * 3)
            .quad("emitter", WALL, (0.0,) * 3, radiance, two_sided=False)
            .build())


# The unit cube's faces, each facing inwards.
CUBE_FACES = {
    "bottom": [(0, 0, 0), (0, 0, 1), (1, 0, 1), (1, 0, 0)],
    "top": [(0, 1, 0), (1, 1, 0), (1, 1, 1), (0, 1, 1)],
    "left": [(0, 0, 0), (0, 1, 0), (0, 1, 1), (0, 0, 1)],
    "right": [(1, 0, 0), (1, 0, 1), (1, 1, 1), (1, 1, 0)],
    "front": [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)],
    "back": [(0, 0, 1), (0, 1, 1), (1, 1, 1), (1, 0, 1)],
}


def furnace_cube(albedo, radiance=1.0):
    """Closed unit cube, every face emitting `radiance` inwards and reflecting `albedo`."""
    builder = SceneBuilder()
    for name, corners in CUBE_FACES.items():
        builder.quad(name, corners, (albedo,) * 3, (radiance,) * 3, two_sided=False)
    return builder.build()


def plane(size=2.0, albedo=0.5, lights=()):
    h = size / 2
    return (SceneBuilder()
            .quad("plane", [(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)], (albedo,) * 3)
            .build(lights))


def inward_sphere(rings=16, segments=32, albedo=0.5, radiance=4.0, cap_rings=3):
    """Unit UV sphere seen from inside (faces point to the centre), its top `cap_rings` rings
    emitting one-sidedly."""
    from native import Scene
    theta = np.pi * np.arange(rings + 1) / rings
    phi = 2 * np.pi * np.arange(segments) / segments
    vertices = np.stack([np.outer(np.sin(theta), np.cos(phi)),
                         np.repeat(np.cos(theta)[:, None], segments, axis=1),
                         np.outer(np.sin(theta), np.sin(phi))], axis=2).reshape(-1, 3)
    index = lambda i, j: i * segments + j % segments
    triangles, emitting = [], []
    for i in range(rings):
        for j in range(segments):
            a, b, c, d = index(i, j), index(i, j + 1), index(i + 1, j + 1), index(i + 1, j)
            # counter-clockwise seen from the centre; the pole rows keep one triangle
            for triangle in ((a, c, b), (a, d, c)):
                if (i == 0 and triangle == (a, c, b)) or (i == rings - 1 and triangle == (a, d, c)):
                    continue
                triangles.append(triangle)
                emitting.append(i < cap_rings)
    emitting = np.array(emitting)
    count = len(triangles)
    return Scene(vertices=vertices, triangles=np.array(triangles),
                 albedo=np.full((count, 3), albedo),
                 emission=np.where(emitting[:, None], radiance, 0.0) * np.ones((count, 3)),
                 emission_two_sided=np.zeros(count, dtype=bool))


def smooth_tube(radius, length, sides, rings):
    """An open tube along x with outward corner normals (shaded smooth), as Blender makes a
    curve's bevel: vertices, triangles, normals."""
    angles = 2 * np.pi * np.arange(sides) / sides
    rim = np.stack([np.zeros(sides), np.cos(angles), np.sin(angles)], axis=1)
    xs = np.linspace(0.0, length, rings + 1)
    vertices = (radius * rim[None] + xs[:, None, None] * np.array([1.0, 0.0, 0.0])).reshape(-1, 3)
    normals = np.tile(rim, (rings + 1, 1))
    triangles = []
    for i in range(rings):
        for j in range(sides):
            a, b = i * sides + j, i * sides + (j + 1) % sides
            c, d = b + sides, a + sides
            triangles += [[a, b, c], [a, c, d]]
    return vertices, np.array(triangles), normals


def open_cone(bottom_radius, top_radius, height, facets):
    """The facets of an open cone about +z from z = 0 to ``height``, each a quad's corners
    counter-clockwise seen from outside."""
    quads = []
    for j in range(facets):
        a0, a1 = 2 * math.pi * j / facets, 2 * math.pi * (j + 1) / facets
        quads.append([(bottom_radius * math.cos(a0), bottom_radius * math.sin(a0), 0.0),
                      (bottom_radius * math.cos(a1), bottom_radius * math.sin(a1), 0.0),
                      (top_radius * math.cos(a1), top_radius * math.sin(a1), height),
                      (top_radius * math.cos(a0), top_radius * math.sin(a0), height)])
    return quads
