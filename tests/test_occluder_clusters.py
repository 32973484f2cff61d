"""A one-sided shooter draws only the clusters of occluders that reach above its plane: an
occluder in front of it still hides what lies behind."""
import numpy as np

import scenes
from native import Settings, Solver
from native.samples import SceneBuilder


def test_a_blocker_of_many_clusters_leaves_the_receiver_dark(ctx, gl_clean):
    """A black 3 m square of 288 triangles halfway between a unit emitter and a unit receiver
    hides the emitter from every receiving texel: zero light."""
    builder = (SceneBuilder()
               .quad("receiver", scenes.RECEIVER, (0.5,) * 3)
               .quad("emitter", scenes.CEILING, (0.0,) * 3, (1.0,) * 3, two_sided=False)
               .quad("blocker", [(-1, -1, 0.5), (2, -1, 0.5), (2, 2, 0.5), (-1, 2, 0.5)],
                     (0.0,) * 3, receive=False, subdivisions=12))
    solver = Solver(builder.build(), Settings(texel_density=16, threshold=0.001, ambient=False,
                                              hemicube_resolution=64), ctx=ctx)
    try:
        assert solver._bake.visibility.cluster_low.shape[0] > 1
        solver.run()
        assert solver.shots > 0
        image, samples = solver.result()[0], solver.texel_samples()[0]
        on_receiver = samples["occupied"] & (np.abs(samples["position"][..., 2]) < 1e-5)
        assert on_receiver.sum() >= 16 * 16
        assert image[on_receiver][:, :3].max() == 0.0
    finally:
        solver.release()
