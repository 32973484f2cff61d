"""Light in slits narrower than a visibility-map texel: a row of books (3 cm wide, 3 mm
apart, 25 cm tall, 22 cm deep) on a 16 x 12 m floor at 4 texels/m, under a 0.6 m light
1.5 m in front of them and 2.9 m up, albedo 0.01 (direct light only), baked with each
hemicube side given.

    python bench/bench_slit_leak.py [--hemicube N ...] [--json PATH]

The truth is a bound, by the flux through the slits' openings: the light the two sides of a
slit absorb came in through its top (3 mm x 22 cm, lit as the books' tops are) and its front
(3 mm x 25 cm, lit as their fronts are), so the sides' mean lightmap value is at most
(top x 0.003 x 0.22 + front x 0.003 x 0.25) / (2 x 0.25 x 0.22) of the same surfaces'. The
outermost sides of the row face the room and are left out. Hemicube 0: the automatic side.
"""
import argparse
from pathlib import Path
import sys

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
from common import device_name, save_results  # noqa: E402
from native import Settings, Solver  # noqa: E402
from native.gpu import create_context  # noqa: E402
from native.preprocess import hemicube_resolution  # noqa: E402
from native.samples import SceneBuilder  # noqa: E402

ALBEDO = 0.01
BOOK = (0.03, 0.22, 0.25)   # width, depth, height
GAP = 0.003
ROW = (-0.5, 0.5)
DENSITY = 4.0


def box(builder, name, low, high):
    """The five faces of a box standing on the floor, counter-clockwise seen from outside."""
    (x0, y0, z0), (x1, y1, z1) = low, high
    for corners in ([(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],
                    [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)],
                    [(x0, y1, z0), (x0, y0, z0), (x0, y0, z1), (x0, y1, z1)],
                    [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],
                    [(x1, y1, z0), (x0, y1, z0), (x0, y1, z1), (x1, y1, z1)]):
        builder.quad(name, corners, (ALBEDO,) * 3, two_sided=False)


def books_scene():
    builder = SceneBuilder()
    builder.quad("floor", [(-8, -6, 0), (8, -6, 0), (8, 6, 0), (-8, 6, 0)], (ALBEDO,) * 3,
                 two_sided=False)
    width, depth, height = BOOK
    x = ROW[0]
    while x + width <= ROW[1]:
        box(builder, "books", (x, 0.0, 0.0), (x + width, depth, height))
        x += width + GAP
    half = 0.3
    builder.quad("light", [(-half, -1.5 - half, 2.9), (-half, -1.5 + half, 2.9),
                           (half, -1.5 + half, 2.9), (half, -1.5 - half, 2.9)],
                 (0.0,) * 3, (50.0,) * 3, two_sided=False, occlude=False)
    return builder.build(), x - GAP


def measure(scene, row_end, ctx, hemicube):
    solver = Solver(scene, Settings(texel_density=DENSITY, ambient=False, threshold=1e-3,
                                    hemicube_resolution=hemicube), ctx=ctx)
    try:
        solver.run()
        image, samples = solver.result()[0], solver.texel_samples()[0]
        side = hemicube_resolution(solver.settings, scene)
    finally:
        solver.release()
    position, normal = samples["position"][..., :3], samples["normal"][..., :3]
    books = samples["occupied"] & (position[..., 2] > 1e-4) & (np.abs(position[..., 0]) < 0.6)
    inner = (position[..., 0] > ROW[0] + 1e-3) & (position[..., 0] < row_end - 1e-3)
    value = image[..., 0]
    tops = value[books & (normal[..., 2] > 0.9)].mean()
    fronts = value[books & (normal[..., 1] < -0.9)].mean()
    sides = value[books & inner & (np.abs(normal[..., 0]) > 0.9)].mean()
    width, depth, height = BOOK
    bound = (tops * GAP * depth + fronts * GAP * height) / (2.0 * height * depth)
    return {"hemicube": side, "tops": float(tops), "fronts": float(fronts),
            "sides": float(sides), "bound": float(bound), "sides_over_bound": float(sides / bound)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--hemicube", type=int, nargs="+", default=[128, 256, 512, 0])
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    ctx = create_context()
    scene, row_end = books_scene()
    rows = []
    for hemicube in args.hemicube:
        row = measure(scene, row_end, ctx, hemicube)
        rows.append(row)
        print(f"hemicube {row['hemicube']:4d}{' (automatic)' if hemicube == 0 else ''}: slit "
              f"sides {row['sides']:.3g}, bound {row['bound']:.3g}, "
              f"over the bound {row['sides_over_bound']:.2f}")
    save_results(args.json, {"device": device_name(ctx), "density": DENSITY, "rows": rows})


if __name__ == "__main__":
    main()
