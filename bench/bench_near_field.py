"""Light a glowing lamp shade gets back from the walls beside it: the realistic interior's
floor-lamp shade (an open cone, radius 0.22 m to 0.15 m over 0.3 m, 24 facets, glowing on
both sides, albedo 0.78) 0.6 m from two walls meeting in a corner (albedo 0.8) over a floor
(albedo 0.5), nothing else lit, at 13 texels/m. The walls' light near the shade is a hot spot
that its blocks shoot as from one quad of even radiance.

    python bench/bench_near_field.py [--json PATH]

The reference is the same solver refined until it stops changing: every block shot texel by
texel (shoot level 0, patches of 5 cm), a 512 x 512 map a face and threshold 0.0005 (a
convergence study, not an independent truth: the interior's own comparison with Cycles is
bench/bench_interior.py). Reported: the mean of the shade's outside texels facing the corner
and the room over the reference's, the shots and the bake's time.
"""
import argparse
import math
from pathlib import Path
import sys
import time

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
from common import device_name, save_results  # noqa: E402
from native import Scene, Settings, Solver  # noqa: E402
from native.gpu import create_context  # noqa: E402

DENSITY = 13.0
SHADE_PROFILE = ((0.22, 0.0), (0.15, 0.3))   # (radius, height) from its foot to its top
SHADE_FACETS = 24
SHADE_ALBEDO, SHADE_RADIANCE = 0.78, 1.0
WALL_ALBEDO, FLOOR_ALBEDO = 0.8, 0.5
REFERENCE = dict(shoot_level=0, patch_size=0.05, hemicube_resolution=512, threshold=0.0005)
RUNS = {
    "default": {},
    "no neighbour vote": dict(neighbour_visibility=False),
    "map 1024": dict(hemicube_resolution=1024),
    "texel by texel": dict(shoot_level=0, patch_size=0.05),
}


def shade():
    """The open cone's vertices and triangles, facing out."""
    angles = 2.0 * math.pi * np.arange(SHADE_FACETS) / SHADE_FACETS
    vertices = np.concatenate([np.stack([r * np.cos(angles), r * np.sin(angles),
                                         np.full(SHADE_FACETS, z)], axis=1)
                               for r, z in SHADE_PROFILE])
    j = np.arange(SHADE_FACETS)
    a, b = j, (j + 1) % SHADE_FACETS
    c, d = b + SHADE_FACETS, a + SHADE_FACETS
    return vertices, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def quad(corners, cells=8):
    """A quad in cells x cells cells, facing the shade."""
    corners = np.asarray(corners, dtype=np.float64)
    normal = np.cross(corners[1] - corners[0], corners[2] - corners[0])
    if normal @ (np.array([0.0, 0.0, 0.15]) - corners.mean(axis=0)) < 0.0:
        corners = corners[::-1]
    s, t = np.meshgrid(np.linspace(0, 1, cells + 1), np.linspace(0, 1, cells + 1), indexing="ij")
    grid = (((1 - s) * (1 - t))[..., None] * corners[0] + (s * (1 - t))[..., None] * corners[1]
            + (s * t)[..., None] * corners[2] + ((1 - s) * t)[..., None] * corners[3])
    index = np.arange((cells + 1) ** 2).reshape(cells + 1, cells + 1)
    a, b = index[:-1, :-1].ravel(), index[1:, :-1].ravel()
    c, d = index[1:, 1:].ravel(), index[:-1, 1:].ravel()
    return grid.reshape(-1, 3), np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def corner_scene():
    parts = [(*shade(), SHADE_ALBEDO, SHADE_RADIANCE)]
    for corners, albedo in (
            ([(0.6, -0.6, -1.3), (0.6, 2.0, -1.3), (0.6, 2.0, 1.4), (0.6, -0.6, 1.4)], WALL_ALBEDO),
            ([(-2.0, -0.6, -1.3), (0.6, -0.6, -1.3), (0.6, -0.6, 1.4), (-2.0, -0.6, 1.4)],
             WALL_ALBEDO),
            ([(-2.0, -0.6, -1.3), (-2.0, 2.0, -1.3), (0.6, 2.0, -1.3), (0.6, -0.6, -1.3)],
             FLOOR_ALBEDO)):
        parts.append((*quad(corners), albedo, 0.0))
    vertices, triangles, albedo, emission, is_shade, base = [], [], [], [], [], 0
    for index, (v, t, rho, radiance) in enumerate(parts):
        vertices.append(v)
        triangles.append(t + base)
        base += len(v)
        albedo += [rho] * len(t)
        emission += [radiance] * len(t)
        is_shade += [index == 0] * len(t)
    is_shade = np.array(is_shade)
    return Scene(vertices=np.concatenate(vertices), triangles=np.concatenate(triangles),
                 albedo=np.repeat(np.array(albedo)[:, None], 3, axis=1),
                 emission=np.repeat(np.array(emission)[:, None], 3, axis=1),
                 emission_two_sided=is_shade, receive_back=is_shade,
                 object_index=(~is_shade).astype(int), object_names=["shade", "room"])


def bake(ctx, **settings):
    settings = {"texel_density": DENSITY, "threshold": 0.002, "ambient": False, **settings}
    started = time.perf_counter()
    solver = Solver(corner_scene(), Settings(**settings), ctx=ctx)
    try:
        solver.run()
        image, samples = solver.result()[0], solver.texel_samples()[0]
        shots = solver.progress.shots
    finally:
        solver.release()
    seconds = time.perf_counter() - started
    position, normal = samples["position"], samples["normal"]
    radius = np.linalg.norm(position[..., :2], axis=-1)
    radial = position[..., :2] / np.maximum(radius, 1e-9)[..., None]
    outside = (samples["occupied"] & (radius < 0.23) & (position[..., 2] > -0.01)
               & (position[..., 2] < 0.31) & ((normal[..., :2] * radial).sum(axis=-1) > 0.5))
    azimuth = np.degrees(np.arctan2(radial[..., 1], radial[..., 0]))
    sides = {"corner": outside & (azimuth > -90.0) & (azimuth < 0.0),
             "room": outside & (np.abs(azimuth) > 90.0)}
    means = {side: float(image[..., 0][mask].mean()) for side, mask in sides.items()}
    return means, shots, seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    ctx = create_context()
    reference, reference_shots, reference_seconds = bake(ctx, **REFERENCE)
    print(f"reference: {reference_shots} shots, {reference_seconds:.1f} s")
    rows = []
    for name, settings in RUNS.items():
        means, shots, seconds = bake(ctx, **settings)
        ratios = {side: means[side] / reference[side] for side in means}
        rows.append({"run": name, "settings": settings, "ratios": ratios, "shots": shots,
                     "seconds": seconds})
        print(f"{name:>18}: facing the corner {ratios['corner']:.3f}, the room "
              f"{ratios['room']:.3f} of the reference; {shots} shots, {seconds:.1f} s")
    save_results(args.json, {"device": device_name(ctx), "density": DENSITY,
                             "reference": {"settings": REFERENCE, "means": reference,
                                           "shots": reference_shots,
                                           "seconds": reference_seconds},
                             "runs": rows})


if __name__ == "__main__":
    main()
