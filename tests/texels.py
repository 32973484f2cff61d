"""Points spread over the surface each lightmap texel covers, from the atlas's charted
triangles: a texel shows the mean over that surface, as a Cycles bake averages its samples
over the texel's square. Truths for texels whose surface bends within them."""
from dataclasses import dataclass

import numpy as np


@dataclass
class TexelLattice:
    rows: np.ndarray      # (K,) the texel each point lies in
    cols: np.ndarray
    points: np.ndarray    # (K, 3) world positions
    normals: np.ndarray   # (K, 3) unit shading normals

    def means(self, values, rows, cols):
        """The mean of per-point ``values`` over each texel (rows[i], cols[i]); NaN where no
        point lies in it."""
        width = max(self.cols.max(), cols.max()) + 1
        sums = np.bincount(self.rows * width + self.cols, values,
                           minlength=(max(self.rows.max(), rows.max()) + 1) * width)
        counts = np.bincount(self.rows * width + self.cols, minlength=len(sums))
        wanted = rows * width + cols
        with np.errstate(invalid="ignore", divide="ignore"):
            return sums[wanted] / counts[wanted]


def texel_lattice(scene, atlas, page=0, grid=4):
    """The points of a grid x grid lattice over every texel square of ``page`` that fall on a
    charted triangle of ``scene`` (the solver's, Solver.scene: with its back-face copies, which
    the atlas indexes), with the shading normal there (the corners' normals interpolated, or
    the face's)."""
    lattice = (np.arange(grid) + 0.5) / grid
    found = []
    for charted in np.nonzero(atlas.page == page)[0]:
        triangle = atlas.triangles[charted]
        uv = atlas.texels[charted]
        low, high = np.floor(uv.min(axis=0)), np.floor(uv.max(axis=0)) + 1
        px, py = np.meshgrid((np.arange(low[0], high[0])[:, None] + lattice).ravel(),
                             (np.arange(low[1], high[1])[:, None] + lattice).ravel())
        p = np.stack([px.ravel(), py.ravel()], axis=1)
        weights = _barycentric(p, uv)
        inside = (weights >= 0.0).all(axis=1)
        p, weights = p[inside], weights[inside]
        corners = scene.vertices[scene.triangles[triangle]]
        if scene.normals is None:
            face = np.cross(corners[1] - corners[0], corners[2] - corners[0])
            normals = np.broadcast_to(face / np.linalg.norm(face), (len(p), 3))
        else:
            normals = weights @ scene.normals[scene.triangles[triangle]]
            normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
        found.append((np.floor(p).astype(int), weights @ corners, normals))
    texels = np.concatenate([texel for texel, _, _ in found])
    return TexelLattice(rows=texels[:, 1], cols=texels[:, 0],
                        points=np.concatenate([points for _, points, _ in found]),
                        normals=np.concatenate([normals for _, _, normals in found]))


def _barycentric(p, uv):
    a, b, c = uv
    cross = lambda u, v: u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
    total = cross(b - a, c - a)
    wa = cross(b - p, c - p) / total
    wb = cross(c - p, a - p) / total
    return np.stack([wa, wb, 1.0 - wa - wb], axis=1)
