"""Scenes with closed-form answers, built through the solver API."""
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


def furnace_cube(albedo, radiance=1.0):
    """Closed unit cube, every face emitting `radiance` inwards and reflecting `albedo`."""
    faces = {
        "bottom": [(0, 0, 0), (0, 0, 1), (1, 0, 1), (1, 0, 0)],
        "top": [(0, 1, 0), (1, 1, 0), (1, 1, 1), (0, 1, 1)],
        "left": [(0, 0, 0), (0, 1, 0), (0, 1, 1), (0, 0, 1)],
        "right": [(1, 0, 0), (1, 0, 1), (1, 1, 1), (1, 1, 0)],
        "front": [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)],
        "back": [(0, 0, 1), (0, 1, 1), (1, 1, 1), (1, 0, 1)],
    }
    builder = SceneBuilder()
    for name, corners in faces.items():
        builder.quad(name, corners, (albedo,) * 3, (radiance,) * 3, two_sided=False)
    return builder.build()


def plane(size=2.0, albedo=0.5, lights=()):
    h = size / 2
    return (SceneBuilder()
            .quad("plane", [(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)], (albedo,) * 3)
            .build(lights))
