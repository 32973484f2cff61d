"""Projection-specific cases of the paper's Section 5 with closed-form truths."""
import numpy as np
import pytest

import analytic
from native import PROJECTIONS, Settings, Solver
from native.samples import SceneBuilder

def rotation(axis, angle):
    """Rodrigues' rotation matrix."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


EMITTER = [(-0.1, -0.1, 0.0), (0.1, -0.1, 0.0), (0.1, 0.1, 0.0), (-0.1, 0.1, 0.0)]


@pytest.mark.parametrize("projection", PROJECTIONS)
def test_a_triangle_almost_edge_on_to_the_shooter_keeps_its_light(ctx, gl_clean, projection):
    """The paper's Figure 4: a receiver seen almost edge-on, near the shooter's horizon, is
    distorted most by hemispherical projections and may vanish from the visibility map. Here
    a wall a few degrees off edge-on stands beside a small emitter on the floor; every wall
    texel must get Lambert's form factor of the emitter."""
    albedo, radiance = 0.5, 10.0
    # The wall stands in the plane y = 0.12, from 1.5 m to 3 m away: seen from the emitter's
    # centre it is 2.3 to 4.6 degrees off edge-on, and all of the emitter lies in front of it.
    base, height = np.array([1.5, 0.12, 0.0]), 1.0
    wall = [base, base + [1.5, 0.0, 0.0], base + [1.5, 0.0, height], base + [0.0, 0.0, height]]
    builder = SceneBuilder()
    builder.quad("floor", [(-1, -1, -0.001), (3, -1, -0.001), (3, 1, -0.001), (-1, 1, -0.001)],
                 (albedo,) * 3, receive=False)
    builder.quad("wall", [tuple(p) for p in wall], (albedo,) * 3)   # faces -y
    builder.quad("emitter", EMITTER, (0.0,) * 3, (radiance,) * 3, two_sided=False)
    solver = Solver(builder.build(), Settings(texel_density=40, shoot_level=0, max_shots=64,
                                              threshold=0.0, projection=projection,
                                              ambient=False), ctx=ctx)
    try:
        solver.run()
        image, samples = solver.result()[0], solver.texel_samples()[0]
    finally:
        solver.release()
    on_wall = samples["occupied"] & (samples["normal"][..., 1] < -0.9)
    points, normals = samples["position"][on_wall], samples["normal"][on_wall]
    expected = albedo * radiance * analytic.polygon_form_factors(points, normals, EMITTER)
    measured = image[on_wall][:, 0]
    assert on_wall.sum() >= 1.5 * 40 * 40 * 0.9
    lit = expected > 1e-3 * expected.max()
    error = np.abs(measured[lit] / expected[lit] - 1)
    assert np.all(error < 0.05)


@pytest.mark.parametrize("subdivision", ["NONE", "REGULAR"])
def test_an_emitter_does_not_light_itself(ctx, gl_clean, subdivision):
    """A grey emitting panel over a black floor receives nothing: its own shots lie in its
    plane, where Lambert's formula jumps to 1 inside the shooter (subdivided texels gather at
    points that rounding puts on either side of that plane)."""
    # Tilted, so that its texels' positions carry rounding off its plane.
    tilt = rotation((0.3, -0.5, 0.8), 0.6)
    panel = [tuple(tilt @ corner + (0.0, 0.0, 1.0)) for corner in
             np.array([(-0.5, -0.5, 0), (-0.5, 0.5, 0), (0.5, 0.5, 0), (0.5, -0.5, 0)])]
    builder = SceneBuilder()
    builder.quad("floor", [(-2, -2, -0.5), (2, -2, -0.5), (2, 2, -0.5), (-2, 2, -0.5)],
                 (0.0,) * 3)
    builder.quad("panel", panel, (0.5,) * 3, (1.0,) * 3, two_sided=False)  # faces down
    solver = Solver(builder.build(), Settings(texel_density=16, subdivision=subdivision,
                                              subdivision_level=2, threshold=0.0,
                                              max_shots=64, ambient=False), ctx=ctx)
    try:
        solver.run()
        image, samples = solver.result()[0], solver.texel_samples()[0]
        ledger = solver.ledger()
    finally:
        solver.release()
    on_panel = samples["occupied"] & (samples["position"][..., 2] > 0.0)
    assert on_panel.sum() >= 16 * 16
    assert np.all(image[on_panel][:, :3] == 0.0)
    assert np.all(ledger.escaped >= 0.0)
