"""The paper's Table 2: RMS error of the hemisphere projections against the hemicube, with
time and shots to a convergence threshold, for the columns and the Cornell box.

    python bench/bench_projections.py --json bench/results/projections-<device>.json
    python bench/bench_projections.py --size-scale 0.125 --threshold 0.03 [--cycles] \\
        --json bench/results/projections-llvmpipe.json   # llvmpipe, 2 cores: about 6 minutes

Each row (subdivision, level, size) is baked with HEMICUBE, HEMISPHERE and NONLINEAR from the
same atlas; the RMS of a hemisphere projection is against the hemicube bake of its own row.

- size: the paper gave each triangle a size x size texture. Our lightmaps are one atlas at a
  texel density, so a size becomes size texels across the scene's reference quad (the Cornell
  box's back wall, the columns' floor; bench/common.py): density = size / side. The paper's
  256 textures gave 512 texels across a quad of two triangles; --size-scale 2 matches that.
  Software rendering is slow with the columns' 3532 triangles: smaller sizes and an earlier
  stop keep it within minutes.
- shooting level: the coarsest whose blocks fit the scene's narrowest object (bench/common.py),
  the nearest we have to the paper's shooting from each triangle's own texture.
- RMS (eq. 1): the root of the mean, over the texels occupied in both lightmaps and outside the
  emitters' near field (emitter_spheres), of the squared
  length of the RGB difference (the printed eq. 1 leaves out the square); relative RMS divides
  it by the root mean square length of the reference's RGB. Lightmap texels are reflected
  radiance, in the scene's own units.
- ADAPTIVE: the paper gave the hemicube the subdivision the hemisphere run had chosen; here each
  projection refines where its own visibility finds shadow edges.
- --cycles (Blender's Python module needed): every bake is also compared with a Cycles DIFFUSE
  bake (direct + indirect + colour, the add-on's reference bake) of the sample .blend into the
  same atlas, one per size, over the texels Cycles wrote outside the emitters' near field
  (emitter_spheres). Cycles' noise adds to this RMS: raise --samples until it stops falling.
"""
import argparse
import importlib
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from common import (ROOT, device_name, load_scene, reference_side, save_results,
                    shoot_level_for, texel_density_for_size)  # also puts the repo on sys.path
from native import Settings, Solver, create_context
from native.evaluation.texel_error import lightmap_error

SCENES = ("columns", "cornell_box")
REFERENCE = "HEMICUBE"
COMPARED = ("HEMISPHERE", "NONLINEAR")
# (subdivision, level, size) in the order of the paper's Table 2.
ROWS = (("NONE", 0, 256), ("ADAPTIVE", 3, 32), ("REGULAR", 3, 32), ("ADAPTIVE", 3, 64),
        ("REGULAR", 3, 64), ("ADAPTIVE", 2, 32), ("REGULAR", 2, 32), ("ADAPTIVE", 2, 64),
        ("REGULAR", 2, 64))


def bake(scene, settings, ctx):
    """Create, run to the threshold and read back; the time covers all three."""
    start = time.perf_counter()
    solver = Solver(scene, settings, ctx=ctx)
    try:
        progress = solver.run()
        pages = solver.result()
        seconds = time.perf_counter() - start
        # Texels in an emitter's near field are left out of every RMS (see emitter_spheres).
        for page, samples in zip(pages, solver.texel_samples()):
            page[..., 3] *= far_from_emitters(scene, samples["position"])
        return pages, {
            "seconds": seconds, "shots": progress.shots, "texels": solver.texel_count,
            "unshot_fraction": progress.unshot_fraction, "converged": progress.converged,
            "phases": dict(solver.timings)}
    finally:
        solver.release()


def rms(pages, reference_pages):
    """Eq. 1 over the texels occupied (alpha 1) in both: (RMS, RMS relative to the reference)."""
    error = lightmap_error(pages, reference_pages)
    return error.rms, error.relative_rms


class CyclesReference:
    """Cycles bakes of one sample .blend, exported as a bake would, into Luxel's atlases: one
    per texel density."""

    def __init__(self, bpy, addon, name, scene, samples, bounces):
        self.bpy, self.addon = bpy, addon
        bpy.ops.wm.open_mainfile(filepath=str(ROOT / "sample_blends" / f"{name}.blend"))
        self.export = addon.export.export_scene(bpy.context)
        exported = self.export.scene
        if not (np.array_equal(exported.vertices, scene.vertices)
                and np.array_equal(exported.triangles, scene.triangles)):
            raise SystemExit(f"bench/scenes/{name}.npz is not {name}.blend as exported now: "
                             "run bench/export_scenes.py")
        self.samples, self.bounces = samples, bounces
        self.pages = {}
        self.seconds = {}
        self.texels = {}

    def page(self, scene, settings, ctx):
        """The bake into the atlas of ``settings``, alpha 1 on the texels compared: those
        Cycles wrote, outside the emitters' near field. Cached by texel density."""
        density = settings.texel_density
        if density not in self.pages:
            # Same scene and density: the atlas the timed bakes use, and its texel positions.
            with Solver(scene, settings, ctx=ctx) as solver:
                atlas, placeholders = solver.atlas, solver.result()
                positions = [page["position"] for page in solver.texel_samples()]
            if atlas.page_count != 1:
                raise SystemExit("--cycles compares one atlas page; lower the size")
            context = self.bpy.context
            # The atlas UVs go onto the objects as a bake would put them there.
            self.addon.writeback.write_back(context.scene, self.export, atlas, placeholders,
                                            placeholders)
            start = time.perf_counter()
            per_object = self.addon.reference.cycles_reference(context, self.samples,
                                                               self.bounces)
            self.seconds[density] = time.perf_counter() - start
            merged = np.zeros_like(placeholders[0])
            for pixels in per_object.values():
                written = pixels[..., 3] > 0.0
                merged[written] = pixels[written]
            merged[..., 3] = (merged[..., 3] > 0.0) * far_from_emitters(scene, positions[0])
            self.pages[density] = [merged]
            self.texels[density] = int(merged[..., 3].sum())
        return self.pages[density]


def far_from_emitters(scene, positions):
    """1 for texel positions outside every emitter's near field, 0 inside."""
    far = np.ones(positions.shape[:2], dtype=np.float32)
    for centre, radius in emitter_spheres(scene):
        far *= np.linalg.norm(positions - centre, axis=2) >= radius
    return far


def emitter_spheres(scene):
    """(centre, radius) around each emitting object: its bounding box's centre and diagonal.
    Within it a shooter's patch-to-point form factor fails (the Cornell box's ceiling is lit
    from 0.1 mm by the light's back face), so texels there are left out of the Cycles RMS."""
    spheres = []
    emitting = scene.emission.max(axis=1) > 0.0
    for index in np.unique(scene.object_index[emitting]):
        corners = scene.vertices[scene.triangles[emitting & (scene.object_index == index)]]
        low, high = corners.reshape(-1, 3).min(axis=0), corners.reshape(-1, 3).max(axis=0)
        spheres.append((0.5 * (low + high), float(np.linalg.norm(high - low))))
    return spheres


def start_blender():
    """bpy with Luxel enabled as a development extension, and the add-on modules used here."""
    sys.path.insert(0, str(ROOT / "tools"))
    import blender  # tools/blender.py, found through the path above
    bpy = blender.start_blender()
    modules = SimpleNamespace(**{name: importlib.import_module(f"{blender.MODULE}.addon.{name}")
                                 for name in ("export", "reference", "writeback")})
    return bpy, modules


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scenes", nargs="+", choices=SCENES, default=list(SCENES))
    parser.add_argument("--threshold", type=float, default=0.01,
                        help="stop at this unshot fraction of the emitted power")
    parser.add_argument("--size-scale", type=float, default=1.0,
                        help="multiplies every row's size (texels across the reference quad)")
    parser.add_argument("--shoot-level", type=int, help="mip level shot from (default: "
                        "blocks as wide as the narrowest object)")
    parser.add_argument("--hemicube", type=int, default=128,
                        help="hemicube face resolution; the hemisphere maps are twice as wide")
    parser.add_argument("--max-shots", type=int, default=100000)
    parser.add_argument("--cycles", action="store_true",
                        help="also compare with Cycles bakes (needs the bpy module)")
    parser.add_argument("--samples", type=int, default=256, help="Cycles samples per texel")
    parser.add_argument("--bounces", type=int, default=32, help="Cycles diffuse bounces")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    blender = start_blender() if args.cycles else None
    ctx = create_context()
    device = device_name(ctx)
    print(f"device: {device}")
    print(f"{'scene':>11} {'subdiv':>8} {'lvl':>3} {'size':>6} {'projection':>10} {'texels':>8} "
          f"{'shots':>6} {'unshot':>7} {'seconds':>8} {'RMS':>10} {'rel. RMS':>9}"
          + (f" {'Cycles RMS':>10} {'rel.':>7}" if args.cycles else ""))
    started = time.perf_counter()
    results = {}
    for name in args.scenes:
        scene = load_scene(name)
        cycles = CyclesReference(*blender, name, scene, args.samples, args.bounces) \
            if blender else None

        def shoot_level(size):
            if args.shoot_level is not None:
                return args.shoot_level
            return shoot_level_for(scene, texel_density_for_size(scene, name, size))

        def settings(projection, subdivision, level, size):
            return Settings(texel_density=texel_density_for_size(scene, name, size),
                            shoot_level=shoot_level(size),
                            threshold=args.threshold, max_shots=args.max_shots,
                            hemicube_resolution=args.hemicube, projection=projection,
                            subdivision=subdivision, subdivision_level=level)

        # Run every projection and subdivision once before anything is timed (shader
        # compilation, driver caches).
        for projection in (REFERENCE,) + COMPARED:
            for subdivision in ("ADAPTIVE", "REGULAR"):
                warm_up = settings(projection, subdivision, 1, 8.0)
                warm_up.max_shots = 2
                bake(scene, warm_up, ctx)

        rows = []
        for subdivision, level, size in ROWS:
            scaled = size * args.size_scale
            row = {"subdivision": subdivision, "level": level, "size": size,
                   "scaled_size": scaled,
                   "texel_density": texel_density_for_size(scene, name, scaled),
                   "shoot_level": shoot_level(scaled),
                   "runs": {}}
            reference_pages = None
            for projection in (REFERENCE,) + COMPARED:
                pages, run = bake(scene, settings(projection, subdivision, level, scaled), ctx)
                line = (f"{name:>11} {subdivision:>8} {level:>3} {scaled:>6.4g} {projection:>10} "
                        f"{run['texels']:>8} {run['shots']:>6} {run['unshot_fraction']:>7.4f} "
                        f"{run['seconds']:>8.2f}")
                if reference_pages is None:
                    reference_pages = pages
                    line += f" {'-':>10} {'-':>9}"
                else:
                    run["rms"], run["relative_rms"] = rms(pages, reference_pages)
                    line += f" {run['rms']:>10.4g} {run['relative_rms']:>9.3%}"
                if cycles:
                    cycles_pages = cycles.page(scene, settings(REFERENCE, subdivision, level,
                                                               scaled), ctx)
                    run["cycles_rms"], run["cycles_relative_rms"] = rms(pages, cycles_pages)
                    line += f" {run['cycles_rms']:>10.4g} {run['cycles_relative_rms']:>7.2%}"
                row["runs"][projection] = run
                print(line, flush=True)
            if cycles:
                row["cycles_seconds"] = cycles.seconds[row["texel_density"]]
                row["cycles_texels"] = cycles.texels[row["texel_density"]]
            rows.append(row)
        results[name] = {"reference_quad_side": reference_side(scene, name),
                         "triangles": len(scene.triangles), "rows": rows}
    ctx.release()
    total = time.perf_counter() - started
    print(f"total: {total:.0f} s")
    save_results(args.json, {
        "device": device, "threshold": args.threshold, "size_scale": args.size_scale,
        "hemicube_resolution": args.hemicube,
        "cycles": {"samples": args.samples, "bounces": args.bounces} if args.cycles else None,
        "total_seconds": total, "scenes": results})


if __name__ == "__main__":
    main()
