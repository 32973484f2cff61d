"""Luxel against a Cycles DIFFUSE bake (direct + indirect + colour) of the Cornell box into the
same lightmap UVs: a check of the units contract. Runs where `import bpy` works (Blender 5.0's
Python module next to the solver's requirements):

    python bench/cycles_parity.py --samples 1024 --json bench/results/cycles-parity.json

The light is a black quad emitting from both faces in both renderers (or, with
--one-sided-light, only downwards), 0.1 mm below the ceiling. Compared: texels fully inside a chart, light excluded; relative RMS
as in the paper's eq. 1 (divided by the reference's RMS), and per-object mean ratios, which
average Cycles' noise away."""
import argparse
import time
from pathlib import Path

import numpy as np

from common import save_results  # also puts the repository on sys.path
from native import Settings, Solver
from native.evaluation.texel_error import lightmap_error
from native.samples import CORNELL_LIGHT, cornell_box

import bpy  # noqa: E402  (after numpy: bpy pins the same numpy)


def luxel_scene(two_sided):
    """The Cornell box with a black light that emits from both faces (as a Blender quad with
    an emission shader does) or only downwards."""
    scene = cornell_box()
    light = scene.object_index == scene.object_names.index("light")
    scene.albedo[light] = 0.0
    scene.emission_two_sided[light] = two_sided
    scene.__post_init__()
    return scene


def cycles_bake(scene, atlas, samples, bounces, two_sided, seed=0):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    blender = bpy.context.scene
    blender.render.engine = "CYCLES"
    blender.cycles.device = "CPU"
    blender.cycles.samples = samples
    blender.cycles.seed = seed
    blender.cycles.use_adaptive_sampling = False
    blender.cycles.use_denoising = False
    blender.cycles.max_bounces = bounces
    blender.cycles.diffuse_bounces = bounces
    blender.cycles.sample_clamp_direct = 0.0    # Blender clamps indirect samples by default
    blender.cycles.sample_clamp_indirect = 0.0
    world = bpy.data.worlds.new("black")  # new worlds shine grey through their node tree
    world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    background.inputs["Strength"].default_value = 0.0
    blender.world = world

    image = bpy.data.images.new("bake", atlas.width, atlas.height, float_buffer=True, alpha=True)
    light_index = scene.object_names.index("light")
    uv = atlas.uv()
    row_of = {int(t): row for row, t in enumerate(atlas.triangles)}
    for index, name in enumerate(scene.object_names):
        if index == light_index:
            continue
        triangles = np.nonzero(scene.object_index == index)[0]
        used, local = np.unique(scene.triangles[triangles], return_inverse=True)
        mesh = bpy.data.meshes.new(name)
        mesh.from_pydata(scene.vertices[used].tolist(), [], local.reshape(-1, 3).tolist())
        layer = mesh.uv_layers.new(name="Lightmap")
        for polygon, triangle in zip(mesh.polygons, triangles):
            for corner, loop in enumerate(polygon.loop_indices):
                layer.data[loop].uv = uv[row_of[int(triangle)], corner]
        material = bpy.data.materials.new(name)
        material.use_nodes = True
        nodes = material.node_tree.nodes
        nodes.clear()
        diffuse = nodes.new("ShaderNodeBsdfDiffuse")
        diffuse.inputs["Color"].default_value = (*scene.albedo[triangles[0]], 1.0)
        output = nodes.new("ShaderNodeOutputMaterial")
        material.node_tree.links.new(diffuse.outputs["BSDF"], output.inputs["Surface"])
        target = nodes.new("ShaderNodeTexImage")
        target.image = image
        nodes.active = target
        mesh.materials.append(material)
        obj = bpy.data.objects.new(name, mesh)
        blender.collection.objects.link(obj)

    # The light as Luxel sees it: a quad with an emission shader (two-sided, like Luxel's
    # default), not baked itself.
    triangles = np.nonzero(scene.object_index == light_index)[0]
    used, local = np.unique(scene.triangles[triangles], return_inverse=True)
    mesh = bpy.data.meshes.new("light")
    mesh.from_pydata(scene.vertices[used].tolist(), [], local.reshape(-1, 3).tolist())
    material = bpy.data.materials.new("light")
    material.use_nodes = True
    nodes = material.node_tree.nodes
    nodes.clear()
    emission = nodes.new("ShaderNodeEmission")
    strongest = max(CORNELL_LIGHT)
    emission.inputs["Color"].default_value = (*(c / strongest for c in CORNELL_LIGHT), 1.0)
    emission.inputs["Strength"].default_value = strongest
    output = nodes.new("ShaderNodeOutputMaterial")
    links = material.node_tree.links
    if two_sided:
        links.new(emission.outputs["Emission"], output.inputs["Surface"])
    else:  # black on the back face
        mix = nodes.new("ShaderNodeMixShader")
        links.new(nodes.new("ShaderNodeNewGeometry").outputs["Backfacing"], mix.inputs["Fac"])
        links.new(emission.outputs["Emission"], mix.inputs[1])
        links.new(mix.outputs["Shader"], output.inputs["Surface"])
    mesh.materials.append(material)
    blender.collection.objects.link(bpy.data.objects.new("light", mesh))

    for obj in blender.objects:
        obj.select_set(obj.name != "light")
    bpy.context.view_layer.objects.active = next(o for o in blender.objects if o.name != "light")
    start = time.perf_counter()
    bpy.ops.object.bake(type="DIFFUSE", pass_filter={"DIRECT", "INDIRECT", "COLOR"}, margin=0,
                        use_clear=True)
    seconds = time.perf_counter() - start
    pixels = np.array(image.pixels[:], dtype=np.float32).reshape(atlas.height, atlas.width, 4)
    return pixels, seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--density", type=float, default=100.0)
    parser.add_argument("--samples", type=int, default=1024)
    parser.add_argument("--bounces", type=int, default=64)
    parser.add_argument("--threshold", type=float, default=0.002)
    parser.add_argument("--one-sided-light", action="store_true",
                        help="the light emits only downwards (Cycles: black back face)")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()

    two_sided = not args.one_sided_light
    scene = luxel_scene(two_sided)
    settings = Settings(texel_density=args.density, threshold=args.threshold,
                        hemicube_resolution=256, max_shots=100000)
    start = time.perf_counter()
    with Solver(scene, settings) as solver:
        solver.run()
        luxel = solver.result()[0]
        samples = solver.texel_samples()[0]
        atlas = solver.atlas
        device = solver.ctx.info["GL_RENDERER"]
        shots = solver.shots
    luxel_seconds = time.perf_counter() - start
    cycles, cycles_seconds = cycles_bake(scene, atlas, args.samples, args.bounces, two_sided)

    # Texels whose square lies fully on one chart, away from the light (which Cycles does not
    # have as a surface).
    occupied = samples["occupied"]
    full = samples["coverage"] > 0.999
    position, normal = samples["position"], samples["normal"]
    distance = np.linalg.norm(position - np.array([0.278, 0.5487, 0.2795]), axis=2)
    compared = occupied & full & (distance > 0.1)
    masked = [np.dstack([image[..., :3], compared]) for image in (luxel, cycles)]
    error = lightmap_error([masked[0]], [masked[1]])
    rms, relative = error.rms, error.relative_rms
    print(f"Luxel ({device}): {shots} shots, {luxel_seconds:.1f} s; Cycles CPU: "
          f"{args.samples} samples, {cycles_seconds:.1f} s")
    print(f"texels compared: {compared.sum()}, RMS {rms:.4g}, relative RMS {relative:.2%}")
    # Surfaces of the box told apart by position and normal; the blocks are the rest.
    walls = {
        "floor": (position[..., 1] < 1e-4) & (normal[..., 1] > 0.99),
        "ceiling": (position[..., 1] > 0.5487) & (normal[..., 1] < -0.99),
        "back wall": (position[..., 2] > 0.5591) & (normal[..., 2] < -0.99),
        "red wall": (position[..., 0] > 0.5495) & (normal[..., 0] < -0.99),
        "green wall": (position[..., 0] < 1e-4) & (normal[..., 0] > 0.99),
    }
    walls["blocks"] = ~np.logical_or.reduce(list(walls.values()))
    surfaces = {}
    for name, mask in walls.items():
        mask = mask & compared
        ratio = luxel[mask][:, :3].sum(axis=0) / cycles[mask][:, :3].sum(axis=0)
        surfaces[name] = ratio.tolist()
        print(f"  {name:>10}: {mask.sum():6d} texels, Luxel / Cycles mean RGB "
              f"{np.round(ratio, 3).tolist()}")
    save_results(args.json, {"device": device, "density": args.density, "samples": args.samples,
                             "two_sided_light": two_sided,
                             "texels": int(compared.sum()), "rms": rms, "relative_rms": relative,
                             "mean_ratio_rgb": surfaces, "luxel_seconds": luxel_seconds,
                             "cycles_seconds": cycles_seconds, "shots": shots})


if __name__ == "__main__":
    main()
