"""Luxel against Cycles inside Blender, one scene per kind of light: ``bpy.ops.luxel.bake()``, then
a Cycles DIFFUSE bake (direct + indirect + colour) of every receiving object into the same
lightmap UVs (addon/reference.py), then each object's mean reflected radiance over the texels
Cycles covered, Luxel's within 5 % of Cycles' per RGB channel (the Cornell box: 2 %). Channels far darker than the
scene's brightest object compare with an absolute tolerance instead.

Cycles' own noise on an object mean, measured once as the spread of 4 seeds at these sample
counts, is at most 0.15 % (Cornell box at 1024 samples and the other scenes at 256), but for
the spot scene's side wall, lit only indirectly (0.64 %): the comparison measures Luxel, not
Cycles. Run with -s to see the per-object table."""
import importlib
import math
import time

import numpy as np
import pytest

import blender_scenes
import blender_session

bpy = blender_session.blender()
reference = importlib.import_module(blender_session.MODULE + ".addon.reference")

RELATIVE = 0.05          # of Cycles' mean, per channel
# The Cornell box at the defaults but its density (30 texels/m) and threshold (0.005): issue 26's
# box at 50 k texels in small. Its floor was 2.6 % over Cycles while the 3x3 neighbour vote lit
# a map texel's width of every shadow edge.
# The panel room: its walls were 5.5-6.7 % dark while the thin gap over the panel kept all
# its light (thin_gap_edges.edge_escape).
RELATIVE_BY_CASE = {"cornell-box": 0.02, "panel-room": 0.03}
ABSOLUTE = 0.01          # of the brightest object's mean in the same channel
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])

STAGE_OBJECTS = {"Floor", "BackWall", "SideWall", "Block"}
ROOM_OBJECTS = {"Floor", "Ceiling", "WallSouth", "WallNorth", "WallWest", "WallEast"}
CORNELL_OBJECTS = {"Floor", "Ceiling", "BackWall", "RedWall", "GreenWall", "ShortBlock",
                   "TallBlock"}

# name: (scene builder, Cycles samples, Cycles bounces, receivers)
CASES = {
    "point": (blender_scenes.point_scene, 256, 32, STAGE_OBJECTS),
    "spot": (blender_scenes.spot_scene, 256, 32, STAGE_OBJECTS),
    "sun": (blender_scenes.sun_scene, 256, 32, STAGE_OBJECTS),
    "area-square": (lambda: blender_scenes.area_scene('SQUARE'), 256, 32, STAGE_OBJECTS),
    "area-rectangle": (lambda: blender_scenes.area_scene('RECTANGLE'), 256, 32, STAGE_OBJECTS),
    "area-disk": (lambda: blender_scenes.area_scene('DISK'), 256, 32, STAGE_OBJECTS),
    "area-ellipse": (lambda: blender_scenes.area_scene('ELLIPSE'), 256, 32, STAGE_OBJECTS),
    "emissive-mesh": (blender_scenes.emissive_scene, 256, 32, STAGE_OBJECTS),
    "world": (blender_scenes.world_scene, 256, 32, STAGE_OBJECTS),
    # The default Principled BSDF (Specular IOR Level 0.5, Roughness 0.5): Cycles' specular
    # layer takes about 3.7 % from the diffuse pass here, and reflects it onto the others
    # (addon/materials.py bakes both shares).
    "point-default-principled": (
        lambda: blender_scenes.point_scene(specular=0.5, roughness=0.5), 256, 32, STAGE_OBJECTS),
    "cornell-box": (blender_scenes.cornell_scene, 1024, 32, CORNELL_OBJECTS),
    "panel-room": (blender_scenes.panel_room_scene, 256, 32, ROOM_OBJECTS),
}


def bake_both(build, samples, bounces):
    """Build the scene, bake it with Luxel and with Cycles; per-object means and timings."""
    started = time.perf_counter()
    scene = build()
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    baked = time.perf_counter()
    pages = reference.cycles_reference(bpy.context, samples=samples, bounces=bounces)
    finished = time.perf_counter()
    stats = scene.luxel.stats
    print(f"\nLuxel {baked - started:.2f} s ({stats.texels} texels, {stats.shots} shots, "
          f"{stats.unshot:.2f} % unshot); Cycles {finished - baked:.2f} s ({samples} samples, "
          f"{bounces} bounces)")
    return reference.object_means(pages)


def print_table(means):
    print(f"{'object':>12} {'texels':>6}  {'Luxel RGB':>26}  {'Cycles RGB':>26}  "
          f"{'Luxel / Cycles':>22}  {'Cycles s.e.':>8}")
    for name, m in means.items():
        error = float(m.cycles_error @ LUMINANCE / max(m.cycles @ LUMINANCE, 1e-30))
        print(f"{name:>12} {m.texels:6d}  {_rgb(m.luxel):>26}  {_rgb(m.cycles):>26}  "
              f"{_rgb(m.ratio, 3):>22}  {error:8.2%}")


def _rgb(values, digits=4):
    return " ".join(f"{v:.{digits}f}" for v in values)


def assert_close(means, expected_objects, relative=RELATIVE):
    assert set(means) == expected_objects
    for m in means.values():
        assert m.texels >= 20, f"{m.name}: Cycles covered only {m.texels} texels"
    brightest = np.max([m.cycles for m in means.values()], axis=0)
    failures = []
    for m in means.values():
        allowed = np.maximum(relative * m.cycles, ABSOLUTE * brightest)
        if np.any(np.abs(m.luxel - m.cycles) > allowed):
            failures.append(f"{m.name}: Luxel {_rgb(m.luxel)}, Cycles {_rgb(m.cycles)}, "
                            f"ratio {_rgb(m.ratio, 3)}")
    assert not failures, "Luxel and Cycles disagree:\n" + "\n".join(failures)


@pytest.mark.parametrize("case", list(CASES))
def test_object_means_match_cycles(case):
    build, samples, bounces, objects = CASES[case]
    means = bake_both(build, samples, bounces)
    print_table(means)
    assert_close(means, objects, relative=RELATIVE_BY_CASE.get(case, RELATIVE))


# An area light of power P emits P whatever its shape: a lone floor 1 m under it gets the same
# mean from Luxel and Cycles to well under 1 % (Cycles' noise here: < 0.05 %).
AREA_POWER_TOLERANCE = 0.005


@pytest.mark.parametrize("shape", ['SQUARE', 'RECTANGLE', 'DISK', 'ELLIPSE'])
def test_area_light_shapes_emit_their_power(shape):
    scene = blender_session.empty_file()
    blender_scenes.quad(scene, "Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)],
                        blender_scenes.material("Floor", (0.5, 0.5, 0.5)))
    size, size_y = (1.3, 0.6) if shape in ('RECTANGLE', 'ELLIPSE') else (1.0, 1.0)
    settings = {"size_y": size_y} if shape in ('RECTANGLE', 'ELLIPSE') else {}
    blender_scenes.light(scene, "AreaLamp", 'AREA', (0.0, 0.0, 1.0), energy=100.0,
                         shape=shape, size=size, **settings)
    blender_scenes.luxel_settings(scene, 7.0)
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    means = reference.object_means(reference.cycles_reference(bpy.context, samples=128,
                                                              bounces=4))
    print_table(means)
    floor = means["Floor"]
    assert abs(floor.ratio[0] - 1.0) < AREA_POWER_TOLERANCE, floor.ratio


# ----------------------------------------------------------- the reference leaves no trace
def _plain(group):
    values = {}
    for prop in group.bl_rna.properties:
        if prop.is_readonly or prop.type in {'POINTER', 'COLLECTION'}:
            continue
        value = getattr(group, prop.identifier)
        values[prop.identifier] = (set(value) if isinstance(value, set) else
                                   tuple(value) if hasattr(value, "__len__")
                                   and not isinstance(value, str) else value)
    return values


def file_state(scene):
    """What a user could see of the file: settings, selection, data-blocks, node trees."""
    view_layer = bpy.context.view_layer
    state = {
        "engine": scene.render.engine,
        "cycles": _plain(scene.cycles),
        "bake": _plain(scene.render.bake),
        "selected": sorted(o.name for o in view_layer.objects if o.select_get()),
        "active": view_layer.objects.active.name if view_layer.objects.active else None,
        "images": sorted(image.name for image in bpy.data.images),
        "materials": sorted(material.name for material in bpy.data.materials),
        "meshes": sorted(mesh.name for mesh in bpy.data.meshes),
    }
    for obj in scene.objects:
        if obj.type == 'MESH':
            layers = obj.data.uv_layers
            state["object " + obj.name] = (
                [(slot.link, slot.material.name if slot.material else None)
                 for slot in obj.material_slots],
                [material.name if material else None for material in obj.data.materials],
                [layer.name for layer in layers], layers.active_index,
                [layer.active_render for layer in layers], obj.luxel.uv_map,
                obj.luxel.image.name if obj.luxel.image else None)
    for material in bpy.data.materials:
        tree = material.node_tree
        state["material " + material.name] = (
            tree.nodes.active.name if tree.nodes.active else None,
            [(node.name, node.bl_idname, node.select, tuple(node.location),
              getattr(node, "image", None) and node.image.name) for node in tree.nodes],
            len(tree.links),
            {key: value.to_dict() if hasattr(value, "to_dict") else value
             for key, value in material.items()})
    return state


def test_reference_leaves_the_file_as_it_was():
    scene = blender_scenes.stage(density=4.0)
    blender_scenes.light(scene, "PointLamp", 'POINT', (0.6, -0.4, 1.9), energy=400.0)
    # A mesh without a material (Cycles and Luxel both shade it 0.8 grey) ...
    blender_scenes.quad(scene, "Bare", [(1.0, -1.5, 0.01), (1.8, -1.5, 0.01), (1.8, -0.7, 0.01),
                                        (1.0, -0.7, 0.01)], None)
    # ... a user's own image node, active, in the floor's material, an object-linked slot ...
    floor_material = bpy.data.materials["Floor"]
    painting = bpy.data.images.new("Painting", 8, 8)
    node = floor_material.node_tree.nodes.new('ShaderNodeTexImage')
    node.image = painting
    floor_material.node_tree.nodes.active = node
    block = bpy.data.objects["Block"]
    block.material_slots[0].link = 'OBJECT'
    block.material_slots[0].material = bpy.data.materials["SideWall"]
    # ... render settings far from the reference's, and a selection.
    scene.render.engine = 'BLENDER_WORKBENCH'
    scene.cycles.samples = 17
    scene.cycles.use_adaptive_sampling = True
    scene.cycles.use_denoising = True
    scene.cycles.max_bounces = 3
    scene.render.bake.margin = 7
    scene.render.bake.use_clear = False
    for obj in scene.objects:
        obj.select_set(obj.name in {"Floor", "PointLamp"})
    bpy.context.view_layer.objects.active = bpy.data.objects["SideWall"]
    assert bpy.ops.luxel.bake() == {'FINISHED'}

    before = file_state(scene)
    pages = reference.cycles_reference(bpy.context, samples=8, bounces=4)
    assert file_state(scene) == before

    assert set(pages) == STAGE_OBJECTS | {"Bare"}
    for name, page in pages.items():
        width, height = bpy.data.objects[name].luxel.image.size
        assert page.shape == (height, width, 4)
        assert set(np.unique(page[..., 3])) <= {0.0, 1.0}
        assert page[..., 3].sum() > 0
        assert np.all(page[page[..., 3] == 0.0][:, :3] == 0.0)
    # Cycles baked the block with its object-linked material, and the bare quad as 0.8 grey.
    means = reference.object_means(pages)
    print_table(means)
    for name in ("Block", "Bare"):
        assert means[name].ratio == pytest.approx(np.ones(3), rel=0.1)

    # Show Baked Lighting on: the reference still bakes the user's shading, not Luxel's
    # preview of the lightmaps, and the preview stays as it was.
    scene.luxel.show_baked = True
    shown = file_state(scene)
    assert shown != before
    again = reference.cycles_reference(bpy.context, samples=8, bounces=4)
    assert file_state(scene) == shown
    for name in pages:
        np.testing.assert_allclose(again[name], pages[name], rtol=1e-5, atol=1e-6)
    scene.luxel.show_baked = False
    assert file_state(scene) == before


def test_reference_restores_the_file_when_cycles_fails():
    scene = blender_scenes.point_scene()
    scene.luxel.texel_density = 3.0
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    before = file_state(scene)
    floor = bpy.data.objects["Floor"]
    floor.data.uv_layers.remove(floor.data.uv_layers[floor.luxel.uv_map])   # bake fails
    before["object Floor"] = file_state(scene)["object Floor"]
    with pytest.raises(RuntimeError):
        reference.cycles_reference(bpy.context, samples=4, bounces=2)
    assert file_state(scene) == before


def test_cycles_noise_is_far_below_the_tolerance():
    """Two seeds of the reference agree on every object mean to well under 1 %."""
    blender_scenes.point_scene()
    bpy.context.scene.luxel.threshold = 0.05
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    first = reference.object_means(reference.cycles_reference(bpy.context, 256, 32, seed=0))
    second = reference.object_means(reference.cycles_reference(bpy.context, 256, 32, seed=1))
    for name in first:
        a, b = first[name].cycles @ LUMINANCE, second[name].cycles @ LUMINANCE
        assert math.isclose(a, b, rel_tol=0.005), (name, a, b)
