"""The extension's defaults through Blender: a scene made in Blender, exported by the add-on
and solved with the settings a new scene's Luxel panel holds, against Lambert's formula. The
lamp is a quad whose material is a pure Emission shader: in Cycles it reflects nothing, and
light it reflected back would put the floor about 4 % over the single bounce."""
import numpy as np

import analytic
import blender_scenes
import blender_session
bpy = blender_session.blender()
addon = blender_session.addon().addon


def test_open_floor_under_an_emission_shader_quad_is_the_single_bounce():
    """A 0.6 x 0.5 m quad, radiance 2 from both faces (Emission shader), 1 m over a 5 x 4 m
    floor of albedo 0.6 (Principled, specular 0), nothing else: every floor texel is
    rho * L * F (Lambert's formula) within 1 % with the panel's defaults."""
    albedo, radiance = 0.6, 2.0
    scene = blender_session.empty_file()
    lamp_corners = [(-0.1, -0.2, 1.0), (0.5, -0.2, 1.0), (0.5, 0.3, 1.0), (-0.1, 0.3, 1.0)]
    blender_scenes.quad(scene, "Floor", [(-2, -1.5, 0), (3, -1.5, 0), (3, 2.5, 0), (-2, 2.5, 0)],
                        blender_scenes.material("Floor", (albedo,) * 3))
    shine = bpy.data.materials.new("Shine")
    if shine.node_tree is None:
        shine.use_nodes = True
    nodes = shine.node_tree.nodes
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = radiance
    shine.node_tree.links.new(emission.outputs[0], nodes["Material Output"].inputs["Surface"])
    blender_scenes.quad(scene, "Lamp", lamp_corners[::-1], shine)   # facing the floor

    job = addon.bake.BakeJob(bpy.context)
    try:
        while not job.step(1.0):
            pass
        image, samples = job.solver.result()[0], job.solver.texel_samples()[0]
    finally:
        job.release()
    occupied = samples["occupied"]
    values, positions = image[occupied][:, :3], samples["position"][occupied]
    normals = samples["normal"][occupied]
    floor = (np.abs(positions[:, 2]) < 1e-4) & (normals[:, 2] > 0.99)
    assert floor.sum() > 6000
    truth = albedo * radiance * analytic.polygon_form_factors(positions[floor], normals[floor],
                                                              lamp_corners)
    relative = values[floor] / truth[:, None] - 1.0
    assert np.abs(relative).max() < 0.01, (relative.min(), relative.max())
