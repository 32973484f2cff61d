"""What a Principled BSDF reflects, as Cycles evaluates it, against what Luxel reflects into
the room: a white furnace per material.

    python bench/bench_glossy_furnace.py [--samples N] [--json PATH]

A hemisphere of the material under a white sky of radiance 1 is baked (COMBINED, reflected
light only, one bounce: a convex hemisphere sees only the sky) from an orthographic camera
on its axis (bake view from the active camera), so that a texel holds the directional albedo
seen at its angle; the hemisphere's UVs are its orthographic projection onto its base, so
every texel weighs the same share of the cosine-weighted hemisphere. Per material: the
diffuse and glossy parts at normal incidence (the pole: what the DIFFUSE and GLOSSY colour
passes that Luxel bakes give, their sum what Luxel reflects), their cosine-weighted means
over the hemisphere (the white-sky albedo: what the surface reflects of light from every
direction alike), and the glossy part seen at a few angles (by reciprocity, the share of
light coming in at that angle that the glossy layers reflect). Green channel.
"""
import argparse
from pathlib import Path
import sys

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(ROOT / "bench"))
import blender as runner  # noqa: E402  (tools/blender.py)
from common import save_results  # noqa: E402

TEXELS = 64
RINGS, SEGMENTS = 48, 96
POLE = 0.2                   # radius of the pole's texels in the projection
COSINES = (0.95, 0.65, 0.35, 0.15)
MATERIALS = {
    "matte (specular 0, roughness 1)": {"Roughness": 1.0, "Specular IOR Level": 0.0},
    "default, roughness 1": {"Roughness": 1.0},
    "default (roughness 0.5)": {},
    "default, roughness 0.2": {"Roughness": 0.2},
    "default, roughness 0.35": {"Roughness": 0.35},
    "default, roughness 0.75": {"Roughness": 0.75},
    "default, base 0.4": {"Base Color": (0.4, 0.4, 0.4, 1.0)},
    "default, base 0.1": {"Base Color": (0.1, 0.1, 0.1, 1.0)},
    "coat 1": {"Coat Weight": 1.0},
    "sheen 1": {"Sheen Weight": 1.0},
    "metal, roughness 0.2": {"Metallic": 1.0, "Roughness": 0.2},
    "metal, roughness 0.5": {"Metallic": 1.0},
    "metal, roughness 1": {"Metallic": 1.0, "Roughness": 1.0},
}


def furnace(bpy, samples):
    scene = bpy.data.scenes.new("Furnace")
    # The reference's settings: no clamping, no Filter Glossy; one bounce, for a convex
    # hemisphere sees only the sky.
    runner.luxel().addon.reference.configure_cycles(scene, samples, bounces=1, seed=0)
    scene.render.bake.view_from = 'ACTIVE_CAMERA'
    world = scene.world = bpy.data.worlds.new("Sky")
    if world.node_tree is None:         # Blender before 5.0 makes it on use_nodes
        world.use_nodes = True
    sky = next(n for n in world.node_tree.nodes if n.bl_idname == 'ShaderNodeBackground')
    sky.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    sky.inputs["Strength"].default_value = 1.0
    polar = np.arange(1, RINGS + 1) / RINGS * np.pi / 2
    azimuth = np.arange(SEGMENTS) / SEGMENTS * 2 * np.pi
    ring = np.stack([np.outer(np.sin(polar), np.cos(azimuth)),
                     np.outer(np.sin(polar), np.sin(azimuth)),
                     np.repeat(np.cos(polar)[:, None], SEGMENTS, axis=1)], axis=2)
    vertices = np.concatenate([[(0.0, 0.0, 1.0)], ring.reshape(-1, 3)])
    following = (np.arange(SEGMENTS) + 1) % SEGMENTS
    faces = [(0, 1 + j, 1 + k) for j, k in enumerate(following)]
    for i in range(RINGS - 1):
        upper, lower = 1 + i * SEGMENTS, 1 + (i + 1) * SEGMENTS
        faces += [(upper + j, lower + j, lower + k, upper + k) for j, k in enumerate(following)]
    mesh = bpy.data.meshes.new("Hemisphere")
    mesh.from_pydata(vertices.tolist(), [], faces)
    mesh.polygons.foreach_set("use_smooth", np.ones(len(faces), dtype=bool))
    corners = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", corners)
    layer = mesh.uv_layers.new(name="Projection")
    layer.uv.foreach_set("vector", ((vertices[corners, :2] + 1) / 2).astype(np.float32).ravel())
    hemisphere = bpy.data.objects.new("Hemisphere", mesh)
    scene.collection.objects.link(hemisphere)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type = 'ORTHO'
    camera.location = (0.0, 0.0, 2.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    image = bpy.data.images.new("Furnace", TEXELS, TEXELS, alpha=True, float_buffer=True)
    image.colorspace_settings.name = 'Linear Rec.709'
    return scene, hemisphere, image


def bake(bpy, scene, hemisphere, image, part):
    image.pixels.foreach_set(np.zeros(TEXELS * TEXELS * 4, dtype=np.float32))
    with bpy.context.temp_override(scene=scene, view_layer=scene.view_layers[0],
                                   selected_objects=[hemisphere],
                                   selected_editable_objects=[hemisphere],
                                   active_object=hemisphere, object=hemisphere):
        bpy.ops.object.bake(type='COMBINED', pass_filter={'DIRECT', 'INDIRECT', part},
                            uv_layer="Projection", margin=0, use_clear=False,
                            target='IMAGE_TEXTURES')
    pixels = np.empty(TEXELS * TEXELS * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    return pixels.reshape(TEXELS, TEXELS, 4)[..., 1]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=64)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    bpy = runner.start_blender()
    scene, hemisphere, image = furnace(bpy, args.samples)
    side = (np.arange(TEXELS) + 0.5) / TEXELS * 2.0 - 1.0
    radius = np.hypot(side[None, :], side[:, None])
    cosine = np.sqrt(np.clip(1.0 - radius ** 2, 0.0, 1.0))
    inside = radius < 1.0
    rows = []
    for name, inputs in MATERIALS.items():
        material = bpy.data.materials.new(name)
        if material.node_tree is None:
            material.use_nodes = True
        principled = material.node_tree.nodes["Principled BSDF"]
        for socket, value in inputs.items():
            principled.inputs[socket].default_value = value
        target = material.node_tree.nodes.new('ShaderNodeTexImage')
        target.image = image
        material.node_tree.nodes.active = target
        hemisphere.data.materials.clear()
        hemisphere.data.materials.append(material)
        diffuse = bake(bpy, scene, hemisphere, image, 'DIFFUSE')
        glossy = bake(bpy, scene, hemisphere, image, 'GLOSSY')
        pole = inside & (radius < POLE)
        row = {"material": name, "inputs": {k: v if np.isscalar(v) else list(v)
                                            for k, v in inputs.items()},
               "diffuse_normal": float(diffuse[pole].mean()),
               "glossy_normal": float(glossy[pole].mean()),
               "diffuse_white_sky": float(diffuse[inside].mean()),
               "glossy_white_sky": float(glossy[inside].mean()),
               "glossy_at": {str(c): float(glossy[inside & (np.abs(cosine - c) < 0.05)].mean())
                             for c in COSINES}}
        row["luxel"] = row["diffuse_normal"] + row["glossy_normal"]
        row["white_sky"] = row["diffuse_white_sky"] + row["glossy_white_sky"]
        rows.append(row)
        print(f"{name:>32}  normal {row['diffuse_normal']:.4f} + {row['glossy_normal']:.4f}"
              f" = {row['luxel']:.4f}   white sky {row['diffuse_white_sky']:.4f} + "
              f"{row['glossy_white_sky']:.4f} = {row['white_sky']:.4f}   glossy at cos "
              + " ".join(f"{c}: {v:.4f}" for c, v in row["glossy_at"].items()), flush=True)
    save_results(args.json, {"samples": args.samples, "texels": TEXELS, "rows": rows})


if __name__ == "__main__":
    main()
