"""The receiver pass over a batch of a selection's shooters gathers what a pass per shooter
does: each texel the sum of the same shooters' light, against each one's own visibility
map (Settings.batched_receivers off shoots one at a time)."""
import numpy as np
import pytest

import scenes
from native import Settings, Solver
from native.samples import cornell_box


def bake(scene, ctx, **settings):
    solver = Solver(scene, Settings(max_shots=64, threshold=0.0, **settings), ctx=ctx)
    try:
        solver.run()
        return solver.result(), solver.shots, solver._bake.state.receiver_batch
    finally:
        solver.release()


@pytest.mark.parametrize("scene, settings", [
    (cornell_box, {"texel_density": 40}),
    (cornell_box, {"texel_density": 20, "subdivision": "REGULAR"}),
    (scenes.inward_sphere, {"texel_density": 8}),
])
def test_a_batch_of_shooters_gathers_what_one_pass_each_does(ctx, gl_clean, scene, settings):
    one_by_one, one_by_one_shots, single = bake(scene(), ctx, batched_receivers=False,
                                                **settings)
    batched, batched_shots, batch = bake(scene(), ctx, **settings)
    assert single == 1 and batch == Settings().shooters_per_selection
    assert batched_shots == one_by_one_shots == 64
    for alone, together in zip(one_by_one, batched):
        occupied = alone[..., 3] > 0.0
        assert occupied.sum() > 100
        scale = np.abs(alone[occupied][:, :3]).max()
        assert scale > 0.0
        np.testing.assert_allclose(together[occupied][:, :3], alone[occupied][:, :3],
                                   rtol=0.0, atol=1e-5 * scale)
