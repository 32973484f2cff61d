"""Small scene builder and the Cornell box, built through the solver API (tests, benchmarks
and the demo bake use them)."""
import numpy as np

from .scene import Scene

CORNELL_WHITE = (0.725, 0.71, 0.68)
CORNELL_RED = (0.63, 0.065, 0.05)
CORNELL_GREEN = (0.14, 0.45, 0.091)
CORNELL_LIGHT = (17.0, 12.0, 4.0)


class SceneBuilder:
    """Collects named quads (two triangles each) with their materials."""

    def __init__(self):
        self._vertices, self._triangles = [], []
        self._albedo, self._emission, self._two_sided, self._receive = [], [], [], []
        self._occlude, self._receive_back = [], []
        self._object_index, self.object_names = [], []

    def quad(self, name, corners, albedo=(0.5, 0.5, 0.5), emission=(0.0, 0.0, 0.0),
             two_sided=True, receive=True, subdivisions=1, occlude=True, receive_back=False):
        """Add a planar quad given by 4 corners in counter-clockwise order seen from its front,
        optionally split into subdivisions x subdivisions cells."""
        if name not in self.object_names:
            self.object_names.append(name)
        obj = self.object_names.index(name)
        c = np.asarray(corners, dtype=np.float64)
        n = subdivisions
        s, t = np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1), indexing="ij")
        grid = ((1 - s) * (1 - t))[..., None] * c[0] + (s * (1 - t))[..., None] * c[1] \
            + (s * t)[..., None] * c[2] + ((1 - s) * t)[..., None] * c[3]
        base = sum(len(v) for v in self._vertices)
        self._vertices.append(grid.reshape(-1, 3))
        index = lambda i, j: base + i * (n + 1) + j
        for i in range(n):
            for j in range(n):
                a, b, cc, d = index(i, j), index(i + 1, j), index(i + 1, j + 1), index(i, j + 1)
                self._triangles += [[a, b, cc], [a, cc, d]]
                for _ in range(2):
                    self._albedo.append(albedo)
                    self._emission.append(emission)
                    self._two_sided.append(two_sided)
                    self._receive.append(receive)
                    self._occlude.append(occlude)
                    self._receive_back.append(receive_back)
                    self._object_index.append(obj)
        return self

    def box(self, name, top, bottom_y, albedo, emission=(0.0, 0.0, 0.0)):
        """A block standing on y = bottom_y whose top face has the 4 given corners (the
        Cornell data's form), with four sides and the top; counter-clockwise seen from above."""
        top = [np.asarray(p, dtype=np.float64) for p in top]
        centre = sum(top) / 4.0
        up = np.cross(top[1] - top[0], top[2] - top[0])
        if up[1] < 0:
            top = top[::-1]
        self.quad(name, top, albedo, emission, two_sided=False)
        for i in range(4):
            a, b = top[i], top[(i + 1) % 4]
            a0, b0 = a.copy(), b.copy()
            a0[1] = b0[1] = bottom_y
            side = [b0, a0, a, b]
            normal = np.cross(side[1] - side[0], side[2] - side[0])
            if normal @ ((a + b) / 2 - centre) < 0:
                side = side[::-1]
            self.quad(name, side, albedo, emission, two_sided=False)
        return self

    def build(self, lights=(), sky=(0.0, 0.0, 0.0)):
        return Scene(
            vertices=np.concatenate(self._vertices), triangles=np.array(self._triangles),
            albedo=np.array(self._albedo, dtype=np.float64),
            emission=np.array(self._emission, dtype=np.float64),
            emission_two_sided=np.array(self._two_sided), receive=np.array(self._receive),
            object_index=np.array(self._object_index), object_names=list(self.object_names),
            occlude=np.array(self._occlude), receive_back=np.array(self._receive_back),
            lights=list(lights), sky=sky)


def cornell_box():
    """The Cornell box (Cornell University Program of Computer Graphics data, converted from
    millimetres to metres, y up) with the common RGB materials and a one-sided area light."""
    mm = 0.001
    w, h, d = 552.8 * mm, 548.8 * mm, 559.2 * mm
    builder = SceneBuilder()
    p = lambda x, y, z: (x * mm, y * mm, z * mm)
    builder.quad("floor", [p(552.8, 0, 0), p(0, 0, 0), p(0, 0, 559.2), p(549.6, 0, 559.2)],
                 CORNELL_WHITE)
    builder.quad("ceiling", [(0, h, 0), (w, h, 0), (w, h, d), (0, h, d)], CORNELL_WHITE)
    builder.quad("back_wall", [(0, 0, d), (0, h, d), (w, h, d), (w, 0, d)], CORNELL_WHITE)
    builder.quad("red_wall", [(w, 0, 0), (w, 0, d), (w, h, d), (w, h, 0)], CORNELL_RED)
    builder.quad("green_wall", [(0, 0, 0), (0, h, 0), (0, h, d), (0, 0, d)], CORNELL_GREEN)
    builder.box("short_block", [p(130, 165, 65), p(82, 165, 225), p(240, 165, 272),
                                p(290, 165, 114)], 0.0, CORNELL_WHITE)
    builder.box("tall_block", [p(423, 330, 247), p(265, 330, 296), p(314, 330, 456),
                               p(472, 330, 406)], 0.0, CORNELL_WHITE)
    builder.quad("light", [p(213, 548.7, 227), p(343, 548.7, 227), p(343, 548.7, 332),
                           p(213, 548.7, 332)], (0.78, 0.78, 0.78), CORNELL_LIGHT,
                 two_sided=False)
    return builder.build()
