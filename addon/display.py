"""The reversible "Show baked lighting" switch.

On: each material of a baked object gets a few nodes of Luxel's feeding a Material Output of
Luxel's that becomes the active one: the lightmap UV map plus the object's and its instancer's
offsets (Attribute nodes, Object and Instancer: writeback's luxel_object and luxel_instancer)
read the page that the instancer's offset names (back faces whose light was solved through
their own UV map), shown as emission, plus the material's own
emission; on an object the bake did not reach (no luxel_object) the material shows its own
shader. The first page's node becomes the active node, which Workbench's Texture colour shows
through the active UV map, so the lightmap UV map becomes the active one of each baked mesh.
An empty material slot of a baked object, or a baked mesh without any, shows the lightmap
through Luxel's own material (FILL_MATERIAL: Blender's default grey and the nodes above) put
in while the switch is on: without a material there is nothing to show it in.
Off: Luxel's nodes and material go, and the user's active output, active node, active UV map
and empty slots come back. Nothing of the user's nodes is edited, so the trees return
exactly."""
import bpy

from .writeback import INSTANCER_OFFSET, OBJECT_OFFSET, PAGE_KEY, UV_MAP, UV_MAP_BACK

NODE_PREFIX = "Luxel "
STATE_KEY = "luxel_display"      # the user's active output and active node while shown
UV_STATE_KEY = "active_uv_maps"  # on scene.luxel: each baked mesh's own active UV map
FILL_MATERIAL = "Luxel Lightmap"
# On a mesh or an object: the slots Luxel's material fills while shown (-1: one it added).
FILLED_KEY = "luxel_filled_slots"


def set_baked_lighting(scene, show):
    hide_baked_lighting(scene)
    if show:
        _show(scene)


def hide_baked_lighting(scene):
    for owner in [*bpy.data.meshes, *bpy.data.objects]:
        if FILLED_KEY in owner:
            _empty_slots(owner)
    for material in bpy.data.materials:
        if STATE_KEY in material:
            strip_display_nodes(material)
    fill = bpy.data.materials.get(FILL_MATERIAL)
    if fill is not None and fill.users == 0:
        bpy.data.materials.remove(fill)
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


def is_fill(material):
    """Whether ``material`` is the one Luxel shows lightmaps in on empty slots (a bake reads
    it as no material)."""
    return material is not None and material.name == FILL_MATERIAL and FILLED_KEY in material


def _show(scene):
    _fill_empty_slots(scene)
    emission = scene.luxel.get("material_emission", {})
    for material, pages in _baked_materials(scene).items():
        if material.node_tree is None:
            continue
        _add_nodes(material, pages, emission.get(material.name))
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
    """{material: the page images (by page number) its baked objects' copies show}."""
    pages = {image[PAGE_KEY]: image for image in bpy.data.images if PAGE_KEY in image
             and image.name.startswith(f"Luxel {scene.name} ")}
    shown = {}
    for obj in scene.objects:       # instancers and objects shown by themselves
        if INSTANCER_OFFSET in obj:
            shown.setdefault(obj, set()).add(int(obj[INSTANCER_OFFSET][2]) - 1)
    found = {}
    for obj in scene.objects:
        if obj.luxel.image is None or not obj.luxel.uv_map or OBJECT_OFFSET not in obj:
            continue
        used = set().union(*(numbers for owner, numbers in shown.items()
                             if owner == obj or _instances(owner, obj)))
        for slot in obj.material_slots:
            if slot.material is not None:
                found.setdefault(slot.material, {}).update(
                    {number: pages[number] for number in used if number in pages})
    return found


def _fill_empty_slots(scene):
    """Luxel's material in each empty slot of a baked object, and in a slot added to a baked
    mesh without any; each filled owner (mesh or object, as the slot links) notes which."""
    def fill():     # made only where a slot needs it: an unused one would linger
        return bpy.data.materials.get(FILL_MATERIAL) or _new_fill_material()

    for obj in scene.objects:
        if obj.type != 'MESH' or obj.luxel.image is None:
            continue
        mesh = obj.data
        if not obj.material_slots and FILLED_KEY not in mesh:
            mesh.materials.append(fill())
            mesh[FILLED_KEY] = [-1]
            continue
        for index, slot in enumerate(obj.material_slots):
            if slot.material is None:
                owner = obj if slot.link == 'OBJECT' else mesh
                slot.material = fill()
                owner[FILLED_KEY] = [*owner.get(FILLED_KEY, []), index]


def _new_fill_material():
    material = bpy.data.materials.new(FILL_MATERIAL)
    if material.node_tree is None:  # Blender before 5.0 makes it on use_nodes
        material.use_nodes = True   # a Principled BSDF of Blender's default grey
    material[FILLED_KEY] = True
    return material


def _empty_slots(owner):
    """Take Luxel's material out of the slots FILLED_KEY lists on ``owner`` (a mesh or an
    object), and the slot it added."""
    for index in sorted(owner[FILLED_KEY], reverse=True):
        if index < 0:   # it had no slot (pop() leaves its objects' slot counts stale)
            owner.materials.clear()
        elif isinstance(owner, bpy.types.Object):
            owner.material_slots[index].material = None
        else:
            owner.materials[index] = None
    del owner[FILLED_KEY]


def _instances(owner, obj):
    collection = owner.instance_collection if owner.instance_type == 'COLLECTION' else None
    return collection is not None and obj.name in collection.all_objects


def _add_nodes(material, pages, own_emission):
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

    uv = add('ShaderNodeUVMap', "UV", -600)
    uv.uv_map = UV_MAP
    offsets = {}
    for key, kind, y in ((OBJECT_OFFSET, 'OBJECT', -150), (INSTANCER_OFFSET, 'INSTANCER', -300)):
        attribute = add('ShaderNodeAttribute', key, -600)
        attribute.location.y += y
        attribute.attribute_type, attribute.attribute_name = kind, key
        offsets[key] = attribute.outputs["Vector"]
    # Back faces whose light was solved (luxel_object's third value 2) read their own map.
    back_uv = add('ShaderNodeUVMap', "Back UV", -800)
    back_uv.uv_map = UV_MAP_BACK
    facing = add('ShaderNodeNewGeometry', "Geometry", -800)
    facing.location.y -= 150
    flags = add('ShaderNodeSeparateXYZ', "Flags", -800)
    flags.location.y -= 450
    links.new(offsets[OBJECT_OFFSET], flags.inputs[0])
    has_back = add('ShaderNodeMath', "Has Back", -700)
    has_back.operation = 'GREATER_THAN'
    has_back.inputs[1].default_value = 1.5
    links.new(flags.outputs["Z"], has_back.inputs[0])
    back_shown = add('ShaderNodeMath', "Back Shown", -700)
    back_shown.location.y -= 150
    back_shown.operation = 'MULTIPLY'
    links.new(facing.outputs["Backfacing"], back_shown.inputs[0])
    links.new(has_back.outputs[0], back_shown.inputs[1])
    side = add('ShaderNodeMix', "Side", -600)
    side.location.y += 150
    side.data_type = 'VECTOR'
    links.new(back_shown.outputs[0], _socket(side.inputs, "Factor_Float"))
    links.new(uv.outputs["UV"], _socket(side.inputs, "A_Vector"))
    links.new(back_uv.outputs["UV"], _socket(side.inputs, "B_Vector"))
    place = _socket(side.outputs, "Result_Vector")
    for key in offsets:
        total = add('ShaderNodeVectorMath', "Place " + key, -400)
        links.new(place, total.inputs[0])
        links.new(offsets[key], total.inputs[1])
        place = total.outputs[0]
    numbers = add('ShaderNodeSeparateXYZ', "Page", -400)
    numbers.location.y -= 300
    links.new(offsets[INSTANCER_OFFSET], numbers.inputs[0])
    light, first = None, None
    for index, (number, image) in enumerate(sorted(pages.items())):
        texture = add('ShaderNodeTexImage', f"Lightmap {number}", -200 + 300 * index)
        texture.image = image
        texture.interpolation = 'Linear'
        texture.extension = 'CLIP'      # a stale modifier's UVs fall off the page: black
        links.new(place, texture.inputs["Vector"])
        first = first or texture
        if light is None:
            light = texture.outputs["Color"]
            continue
        this_page = add('ShaderNodeMath', f"Page {number}", -200 + 300 * index)
        this_page.location.y -= 300
        this_page.operation = 'COMPARE'
        this_page.inputs[1].default_value, this_page.inputs[2].default_value = number + 1, 0.25
        links.new(numbers.outputs["Z"], this_page.inputs[0])
        choose = add('ShaderNodeMix', f"Choose {number}", -50 + 300 * index)
        choose.data_type = 'RGBA'
        links.new(this_page.outputs[0], choose.inputs["Factor"])
        links.new(light, _socket(choose.inputs, "A_Color"))
        links.new(texture.outputs["Color"], _socket(choose.inputs, "B_Color"))
        light = _socket(choose.outputs, "Result_Color")
    x = 300 * len(pages)
    shader = add('ShaderNodeEmission', "Baked Light", x)
    if light is not None:
        links.new(light, shader.inputs["Color"])
    if own_emission is not None and max(own_emission) > 0.0:
        glow = add('ShaderNodeEmission', "Own Emission", x)
        glow.location.y -= 150
        glow.inputs["Color"].default_value = (*own_emission, 1.0)
        total = add('ShaderNodeAddShader', "Sum", x + 200)
        links.new(shader.outputs[0], total.inputs[0])
        links.new(glow.outputs[0], total.inputs[1])
        shader = total
    # An object the bake did not reach shows the material's own shader.
    baked = add('ShaderNodeMath', "Baked", x + 200)
    baked.location.y -= 300
    baked.operation = 'MINIMUM'
    baked.inputs[1].default_value = 1.0
    links.new(flags.outputs["Z"], baked.inputs[0])
    either = add('ShaderNodeMixShader', "Baked Or Own", x + 400)
    links.new(baked.outputs[0], either.inputs["Fac"])
    own = next((n for n in outputs if n.name == active_output), None)
    if own is not None and own.inputs["Surface"].is_linked:
        links.new(own.inputs["Surface"].links[0].from_socket, either.inputs[1])
    links.new(shader.outputs[0], either.inputs[2])
    output = add('ShaderNodeOutputMaterial', "Output", x + 600)
    links.new(either.outputs[0], output.inputs["Surface"])
    output.is_active_output = True
    nodes.active = first


def _socket(sockets, identifier):
    return next(socket for socket in sockets if socket.identifier == identifier)


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
