"""Camera views for the comparison: the scene's cameras, topped up with automatic views, each
rendered twice by Cycles into linear radiance: once path traced (the diffuse light transport
only) and once with Luxel's lightmaps displayed (Show Baked Lighting, emission only).

Both renders go through the same compositor group, (diffuse direct + indirect) x diffuse colour
+ emission + environment, so specular layers of the user's materials (which Luxel does not
model) are left out of both. The user's render settings, camera, view layer passes and
compositor come back afterwards; the temporary cameras and node group are removed."""
from dataclasses import dataclass
import os
import tempfile

import bpy
from mathutils import Vector
import numpy as np

from ..native import read_exr
from .reference import SettingsSnapshot, configure_cycles

TEMP_PREFIX = "Luxel Compare "
PASSES = ("diffuse_direct", "diffuse_indirect", "diffuse_color", "emit", "environment")
AUTOMATIC_LENS_MM = 18.0
# Luxel's view is emission only: its samples only anti-alias edges.
LUXEL_VIEW_SAMPLES = 32


@dataclass
class View:
    name: str
    source: str           # 'camera' or 'automatic'
    cycles: np.ndarray    # (H, W, 3) linear radiance, top row first; None: not rendered
    luxel: np.ndarray


def render_views(context, count, resolution, samples, bounces=32, seed=0, *, path_traced=True):
    """Render ``count`` views at ``resolution`` (width, height), Cycles at ``samples``; with
    ``path_traced`` False only the lightmaps' views (View.cycles None)."""
    scene = context.scene
    view_layer = context.view_layer
    restore = SettingsSnapshot(scene, (scene.cycles, scene.render, scene.render.image_settings,
                                       view_layer))
    camera = scene.camera
    compositor = scene.compositing_node_group
    show_baked = scene.luxel.show_baked
    temporary = []
    tree = None
    folder = tempfile.mkdtemp(prefix="luxel-views-")
    try:
        cameras = _scene_cameras(scene)[:count]
        automatic = _automatic_cameras(scene, count - len(cameras), resolution, temporary)
        # The render-layer node offers only the passes enabled when it is made.
        _configure_render(scene, view_layer, resolution, os.path.join(folder, "view.exr"))
        tree = _diffuse_compositor(scene)
        views = []
        for obj, source in ([(c, 'camera') for c in cameras]
                            + [(c, 'automatic') for c in automatic]):
            scene.camera = obj
            name = obj.name[len(TEMP_PREFIX):] if source == 'automatic' else obj.name
            cycles = None
            if path_traced:
                scene.luxel.show_baked = False
                configure_cycles(scene, samples, bounces, seed)
                cycles = _render(scene)
            scene.luxel.show_baked = True
            configure_cycles(scene, min(samples, LUXEL_VIEW_SAMPLES), bounces, seed)
            luxel = _render(scene)
            views.append(View(name, source, cycles, luxel))
        return views
    finally:
        if scene.luxel.show_baked != show_baked:
            scene.luxel.show_baked = show_baked
        scene.camera = camera
        scene.compositing_node_group = compositor
        if tree is not None:
            bpy.data.node_groups.remove(tree)
        for obj in temporary:
            data = obj.data
            bpy.data.objects.remove(obj)
            bpy.data.cameras.remove(data)
        restore()
        for name in os.listdir(folder):
            os.unlink(os.path.join(folder, name))
        os.rmdir(folder)


def _scene_cameras(scene):
    return sorted((obj for obj in scene.objects if obj.type == 'CAMERA'
                   and not obj.hide_render), key=lambda obj: (obj != scene.camera, obj.name))


def _automatic_cameras(scene, count, resolution, temporary):
    """Views from inside the bounds of the scene's meshes: four from the upper corners looking
    across and down to the opposite side, one from above the centre looking down (rooms are
    seen from inside, open scenes from within their extent)."""
    if count <= 0:
        return []
    low, high = _mesh_bounds(scene)
    centre, half = (low + high) / 2, (high - low) / 2
    eyes_and_targets = []
    for sx, sy in ((-1, -1), (1, 1), (1, -1), (-1, 1)):
        eye = centre + Vector((0.7 * sx * half.x, 0.7 * sy * half.y, 0.6 * half.z))
        target = centre + Vector((-0.3 * sx * half.x, -0.3 * sy * half.y, -0.4 * half.z))
        eyes_and_targets.append((eye, target))
    top = centre + Vector((0.0, 0.0, 0.8 * half.z))
    eyes_and_targets.append((top, centre + Vector((0.0, 0.1 * half.y + 1e-3, -half.z))))
    cameras = []
    for index in range(count):
        eye, target = eyes_and_targets[index % len(eyes_and_targets)]
        data = bpy.data.cameras.new(f"{TEMP_PREFIX}view {index + 1}")
        data.lens = AUTOMATIC_LENS_MM
        data.sensor_fit = 'HORIZONTAL' if resolution[0] >= resolution[1] else 'VERTICAL'
        data.clip_start = 1e-3 * max(half.length, 1.0)
        data.clip_end = 10.0 * max(half.length, 1.0)
        obj = bpy.data.objects.new(f"{TEMP_PREFIX}view {index + 1}", data)
        scene.collection.objects.link(obj)
        temporary.append(obj)
        obj.location = eye
        obj.rotation_euler = (target - eye).to_track_quat('-Z', 'Z').to_euler()
        cameras.append(obj)
    return cameras


def _mesh_bounds(scene):
    corners = [obj.matrix_world @ Vector(corner) for obj in scene.objects
               if obj.type == 'MESH' and not obj.hide_render for corner in obj.bound_box]
    if not corners:
        return Vector((-1.0, -1.0, -1.0)), Vector((1.0, 1.0, 1.0))
    array = np.array([tuple(c) for c in corners])
    return Vector(array.min(axis=0)), Vector(array.max(axis=0))


def _diffuse_compositor(scene):
    """A compositor group whose output is the diffuse transport and what is seen directly."""
    tree = bpy.data.node_groups.new(TEMP_PREFIX + "Diffuse", "CompositorNodeTree")
    tree.interface.new_socket("Image", in_out='OUTPUT', socket_type='NodeSocketColor')
    layers = tree.nodes.new('CompositorNodeRLayers')
    layers.scene = scene
    output = tree.nodes.new('NodeGroupOutput')
    passes = layers.outputs

    def mix(blend, a, b):
        node = tree.nodes.new('ShaderNodeMix')
        node.data_type, node.blend_type = 'RGBA', blend
        node.inputs["Factor"].default_value = 1.0
        # The colour sockets of ShaderNodeMix (its float and vector ones share their names).
        tree.links.new(a, node.inputs[6])
        tree.links.new(b, node.inputs[7])
        return node.outputs[2]

    light = mix('ADD', passes["Diffuse Direct"], passes["Diffuse Indirect"])
    seen = mix('ADD', passes["Emission"], passes["Environment"])
    tree.links.new(mix('ADD', mix('MULTIPLY', light, passes["Diffuse Color"]), seen),
                   output.inputs[0])
    scene.compositing_node_group = tree
    return tree


def _configure_render(scene, view_layer, resolution, path):
    render = scene.render
    render.resolution_x, render.resolution_y = resolution
    render.resolution_percentage = 100
    render.pixel_aspect_x = render.pixel_aspect_y = 1.0
    render.use_border = False
    render.use_compositing = True
    render.use_sequencer = False
    render.film_transparent = False
    render.filepath = path
    render.use_file_extension = False
    settings = render.image_settings
    settings.media_type = 'IMAGE'
    settings.file_format = 'OPEN_EXR'
    settings.color_depth = '32'
    settings.color_mode = 'RGBA'
    for name in PASSES:
        setattr(view_layer, "use_pass_" + name, True)


def _render(scene):
    bpy.ops.render.render(write_still=True)
    return np.flipud(read_exr(scene.render.filepath)[..., :3]).copy()
