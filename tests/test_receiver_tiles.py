"""The receiver pass draws only the tiles of texels that can receive a shot: none of the
texels it leaves out is in front of the shooter's plane and facing it."""
import numpy as np

from native import Settings, Solver, receivers
from native.samples import cornell_box
from native.state import decode_normals, read_map


def test_tiles_left_out_hold_no_texel_in_front_of_the_shooter_and_facing_it(ctx, gl_clean):
    solver = Solver(cornell_box(), Settings(texel_density=40, max_shots=24, threshold=0.0),
                    ctx=ctx)
    try:
        state = solver._bake.state
        tiles, epsilon = state.receiver_tiles, state.bounds.epsilon
        maps = [(read_map(page.textures["position"]), decode_normals(
            read_map(page.textures["normal"]))) for page in state.pages]
        shooters = []
        original = receivers.receiving_tiles

        def recording(tiles, shooter, epsilon):
            shooters.append(shooter)
            return original(tiles, shooter, epsilon)
        receivers.receiving_tiles = recording
        try:
            solver.run()
        finally:
            receivers.receiving_tiles = original
        assert len(shooters) > 8
        left_out_share = []
        for shooter in shooters:
            receiving = receivers.receiving_tiles(tiles, shooter, epsilon)
            left_out_share.append(1.0 - receiving.mean())
            for tile in np.flatnonzero(~receiving):
                x0, y0, x1, y1 = tiles.boxes[tile]
                position, normal = (m[y0:y1, x0:x1] for m in maps[tiles.page[tile]])
                held = position[..., 3] > 0.0
                offset = position[held][:, :3] - shooter.centre
                # receive_patch.frag: light only above the plane, on a normal facing it.
                lit = (offset @ shooter.frame[:, 2] > epsilon) & (
                    np.einsum("ij,ij->i", normal[held], offset) < 0.0)
                assert not lit.any()
        # Every shooter lies on a wall or a box of the closed box: its own plane at least.
        assert min(left_out_share) > 0.0 and np.mean(left_out_share) > 0.25
    finally:
        solver.release()
