"""The reversible "Show baked lighting" switch.

On: each material of a baked object gets a few nodes of Luxel's (its lightmap through the
lightmap UV map, shown as emission, plus the material's own emission) feeding a Material Output
of Luxel's that becomes the active one, and the lightmap node becomes the active node, which
Workbench's Texture colour shows through the active UV map, so the lightmap UV map becomes the
active one of each baked mesh. Off: Luxel's nodes go, and the user's active output, active node
and active UV map come back. Nothing of the user's nodes is edited, so the trees return
exactly."""
import bpy

from .writeback import UV_MAP

NODE_PREFIX = "Luxel "
STATE_KEY = "luxel_display"      # the user's active output and active node while shown
UV_STATE_KEY = "active_uv_maps"  # on scene.luxel: each baked mesh's own active UV map


def set_baked_lighting(scene, show):
    hide_baked_lighting(scene)
    if show:
        _show(scene)


def hide_baked_lighting(scene):
    for material in bpy.data.materials:
        if STATE_KEY in material:
            strip_display_nodes(material)
    settings = scene.luxel
    for mesh_name, uv_name in settings.get(UV_STATE_KEY, {}).items():
        mesh = bpy.data.meshes.get(mesh_name)
        if mesh is not None and uv_name in mesh.uv_layers:
            mesh.uv_layers.active = mesh.uv_layers[uv_name]
    if UV_STATE_KEY in settings:
        del settings[UV_STATE_KEY]


def refresh(scene):
    """After a bake: show the new images if the switch is on."""
    if scene.luxel.show_baked:
        set_baked_lighting(scene, True)


def _show(scene):
    emission = scene.luxel.get("material_emission", {})
    for material, image in _baked_materials(scene).items():
        if material.node_tree is None:
            continue
        _add_nodes(material, image, emission.get(material.name))
    active_uv_maps = {}
    for obj in scene.objects:
        layers = obj.data.uv_layers if obj.type == 'MESH' else None
        if layers is None or obj.luxel.image is None or obj.luxel.uv_map not in layers:
            continue
        if layers.active is not None:
            active_uv_maps[obj.data.name] = layers.active.name
        layers.active = layers[obj.luxel.uv_map]
    scene.luxel[UV_STATE_KEY] = active_uv_maps


def _baked_materials(scene):
    found = {}
    for obj in scene.objects:
        if obj.luxel.image is None or not obj.luxel.uv_map:
            continue
        for slot in obj.material_slots:
            if slot.material is not None:
                found.setdefault(slot.material, obj.luxel.image)
    return found


def _add_nodes(material, image, own_emission):
    tree = material.node_tree
    nodes, links = tree.nodes, tree.links
    outputs = [n for n in nodes if n.bl_idname == 'ShaderNodeOutputMaterial']
    active_output = next((n.name for n in outputs if n.is_active_output), "")
    active_node = nodes.active.name if nodes.active is not None else ""
    material[STATE_KEY] = {"output": active_output, "active": active_node}

    left = min((n.location.x for n in nodes), default=0.0)
    top = max((n.location.y for n in nodes), default=0.0) + 400.0

    def add(kind, name, x):
        node = nodes.new(kind)
        node.name = node.label = NODE_PREFIX + name
        node.location = (left + x, top)
        return node

    uv = add('ShaderNodeUVMap', "UV", 0)
    uv.uv_map = UV_MAP
    texture = add('ShaderNodeTexImage', "Lightmap", 200)
    texture.image = image
    texture.interpolation = 'Linear'
    shader = add('ShaderNodeEmission', "Baked Light", 500)
    links.new(uv.outputs["UV"], texture.inputs["Vector"])
    links.new(texture.outputs["Color"], shader.inputs["Color"])
    if own_emission is not None and max(own_emission) > 0.0:
        glow = add('ShaderNodeEmission', "Own Emission", 500)
        glow.location.y -= 150
        glow.inputs["Color"].default_value = (*own_emission, 1.0)
        total = add('ShaderNodeAddShader', "Sum", 700)
        links.new(shader.outputs[0], total.inputs[0])
        links.new(glow.outputs[0], total.inputs[1])
        shader = total
    output = add('ShaderNodeOutputMaterial', "Output", 900)
    links.new(shader.outputs[0], output.inputs["Surface"])
    output.is_active_output = True
    nodes.active = texture


def strip_display_nodes(material):
    """Remove Luxel's nodes from ``material`` and give back the user's active output and active
    node (also used on the Cycles reference's copies of shown materials)."""
    state = material[STATE_KEY]
    tree = material.node_tree
    if tree is not None:
        for node in [n for n in tree.nodes if n.name.startswith(NODE_PREFIX)]:
            tree.nodes.remove(node)
        output = tree.nodes.get(state.get("output", ""))
        if output is not None:
            output.is_active_output = True
        tree.nodes.active = tree.nodes.get(state.get("active", ""))
    del material[STATE_KEY]
