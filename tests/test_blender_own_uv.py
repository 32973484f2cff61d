"""An object baked through a lightmap UV map of its own (Object > Luxel Lightmap > UV Source):
Luxel's UV map is that map under one scale and offset, the map itself is untouched, the light
matches Cycles, and a map whose faces overlap or leave [0, 1] is refused before anything
changes."""
import importlib

import numpy as np
import pytest

import blender_scenes
import blender_session
from test_blender_parity import STAGE_OBJECTS, assert_close, print_table

bpy = blender_session.blender()
reference = importlib.import_module(blender_session.MODULE + ".addon.reference")

# One rectangle per face of the stage's block (four sides, then the top), gaps between them.
RECTANGLES = [((0.05, 0.05), (0.35, 0.35)), ((0.4, 0.05), (0.7, 0.35)),
              ((0.05, 0.45), (0.35, 0.75)), ((0.4, 0.45), (0.7, 0.75)),
              ((0.75, 0.05), (0.95, 0.65))]


def give_own_map(obj, rectangles, name="Lightmap"):
    """A UV map with each face's corners, in loop order, on one rectangle's corners."""
    obj.data.uv_layers.new(name="UVMap")
    layer = obj.data.uv_layers.new(name=name)
    for polygon, ((u0, v0), (u1, v1)) in zip(obj.data.polygons, rectangles):
        for loop, corner in zip(polygon.loop_indices, [(u0, v0), (u1, v0), (u1, v1), (u0, v1)]):
            layer.uv[loop].vector = corner
    obj.luxel.uv_source = 'MAP'
    obj.luxel.source_uv_map = name
    return layer


def uv_of(obj, name):
    values = np.empty(len(obj.data.loops) * 2)
    obj.data.uv_layers[name].uv.foreach_get("vector", values)
    return values.reshape(-1, 2)


def test_own_map_is_packed_as_it_is_and_matches_cycles():
    scene = blender_scenes.point_scene()
    block = scene.objects["Block"]
    give_own_map(block, RECTANGLES)
    before = {name: uv_of(block, name) for name in ("UVMap", "Lightmap")}
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    for name, values in before.items():
        np.testing.assert_array_equal(uv_of(block, name), values)
    own, baked = before["Lightmap"], uv_of(block, "LuxelLightmap")
    scale = np.ptp(baked, axis=0) / np.ptp(own, axis=0)
    np.testing.assert_allclose(scale[0], scale[1], rtol=1e-4)      # one scale
    np.testing.assert_allclose(baked, own * scale + (baked - own * scale).mean(axis=0),
                               atol=1e-5)
    means = reference.object_means(reference.cycles_reference(bpy.context, samples=256,
                                                              bounces=32))
    print_table(means)
    assert_close(means, STAGE_OBJECTS)


@pytest.mark.parametrize("problem, rectangles", [
    ("UV map 'Lightmap' has 2 faces overlapping others", RECTANGLES[:3] + [RECTANGLES[2]] + RECTANGLES[4:]),
    ("UV map 'Lightmap' has 1 face outside the",
     RECTANGLES[:4] + [((0.75, 0.05), (1.2, 0.65))]),
])
def test_overlapping_or_outside_own_map_is_refused_and_nothing_changes(problem, rectangles):
    scene = blender_scenes.point_scene()
    block = scene.objects["Block"]
    give_own_map(block, rectangles)
    with pytest.raises(RuntimeError, match=f"'Block': {problem}"):
        bpy.ops.luxel.bake()
    assert not bpy.data.images
    assert all("LuxelLightmap" not in obj.data.uv_layers for obj in scene.objects
               if obj.type == 'MESH')
    assert not scene.luxel.stats.valid


def test_own_map_missing_is_refused_naming_the_object():
    scene = blender_scenes.point_scene()
    block = scene.objects["Block"]
    block.luxel.uv_source = 'MAP'
    block.luxel.source_uv_map = "Nowhere"
    with pytest.raises(RuntimeError, match="'Block' has no UV map 'Nowhere'"):
        bpy.ops.luxel.bake()
    assert not bpy.data.images
