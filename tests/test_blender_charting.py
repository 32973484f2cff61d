"""Charting a mesh as Blender subdivides it: xatlas cuts some of its quads between two charts,
each such quad goes whole into the chart of its larger triangle, and a chart that leaves
empty keeps no number: the tight packing places a box for every chart number, and an empty
chart's bounds are not finite."""
import importlib
import warnings

import numpy as np

import blender_session

bpy = blender_session.blender()
native = importlib.import_module(blender_session.MODULE + ".native")
atlas_module = importlib.import_module(blender_session.MODULE + ".native.atlas")
packing = importlib.import_module(blender_session.MODULE + ".native.packing")
export = importlib.import_module(blender_session.MODULE + ".addon.export")


def test_every_chart_of_a_subdivided_pole_holds_triangles():
    """A 4 x 4 cm pole 1.4 m tall under five levels of Subdivision Surface (a lamp's pole in
    a room whose furniture is subdivided) at 40 texels/m: one of xatlas's charts held only
    quads that moved whole into a neighbour."""
    blender_session.empty_file()
    bpy.ops.mesh.primitive_cube_add(size=1.0)
    pole = bpy.context.object
    pole.scale = (0.04, 0.04, 1.4)
    bpy.ops.object.transform_apply(scale=True)
    subdivision = pole.modifiers.new("Subdivision", 'SUBSURF')
    subdivision.levels = subdivision.render_levels = 5
    bpy.ops.object.light_add(type='POINT', location=(1.0, 1.0, 1.0))
    scene = export.export_scene(bpy.context).scene
    atlas_module.clear_cache()
    atlas = native.lightmap_atlas(scene, native.Settings(texel_density=40.0))
    assert len(atlas.triangles) == len(scene.with_back_faces().triangles)
    np.testing.assert_array_equal(np.unique(atlas.chart), np.arange(atlas.chart.max() + 1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")      # an empty chart's infinite bounds cast to int
        tight, texel_map = packing.tight_packing(atlas, 4)
    assert texel_map is not None
    assert len(texel_map.offsets) == atlas.chart.max() + 1
