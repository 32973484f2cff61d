"""Patches that shoot have a world size (Settings.patch_size): the shots a bake needs follow
the scene, not how finely its texels sample it, and the light stays right."""
import numpy as np
import pytest

import analytic
import scenes
from native import Settings, Solver


def bake(scene, ctx, **settings):
    solver = Solver(scene, Settings(ambient=False, hemicube_resolution=64, **settings), ctx=ctx)
    try:
        solver.run()
        return solver.result()[0], solver.texel_samples()[0], solver.progress
    finally:
        solver.release()


def test_doubling_the_density_keeps_the_furnace_shots_and_its_closed_form(ctx, gl_clean):
    """Closed cube, emission 1, albedo rho: rho / (1 - rho) everywhere. Four times the texels
    shoot from the same patches: about as many shots (blocks of texels: four times as many)."""
    albedo = 0.5
    shots = {}
    for density in (8, 16):
        image, samples, progress = bake(scenes.furnace_cube(albedo), ctx, texel_density=density,
                                        shoot_level=0, patch_size=0.25, threshold=0.002)
        assert progress.converged
        occupied = samples["occupied"]
        assert occupied.sum() == 6 * density * density
        values = image[occupied][:, :3]
        assert np.max(np.abs(values / (albedo / (1 - albedo)) - 1)) < 0.01
        shots[density] = progress.shots
    assert shots[16] <= 1.25 * shots[8]


@pytest.mark.parametrize("density", [16, 32])
def test_patches_wider_than_texels_light_the_receiver_by_lamberts_formula(ctx, gl_clean,
                                                                           density):
    """A unit emitter over a unit receiver, shot from 0.25 m patches at 4 and 8 texels a
    patch: every receiving texel within 3 % of rho L F (the corner formula)."""
    radiance = np.array([1.0, 2.0, 0.5])
    albedo = 0.5
    image, samples, _ = bake(scenes.parallel_squares(radiance, albedo), ctx,
                             texel_density=density, shoot_level=0, patch_size=0.25,
                             threshold=0.001)
    on_plane = samples["occupied"] & (np.abs(samples["position"][..., 2]) < 1e-5) \
        & (samples["normal"][..., 2] > 0.99)
    rows, cols = np.nonzero(on_plane)
    expected_f = np.array([analytic.parallel_rectangle_form_factor(x, y, 0, 1, 0, 1, 1.0)
                           for x, y in samples["position"][rows, cols, :2]])
    measured = image[rows, cols, :3]
    assert np.max(np.abs(measured / (albedo * radiance * expected_f[:, None]) - 1)) < 0.03
