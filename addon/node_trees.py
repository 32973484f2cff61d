"""What a material's node tree does, read without evaluating it: its active Cycles output,
the nodes that feed it, whether its result may vary over a surface or may emit, and what a
bake of its copy on a copy of the mesh cannot give as the scene renders it (materials.py
evaluates the materials; export.py marks the emitters)."""
from .display import NODE_PREFIX, STATE_KEY

# What a material's copy cannot give as the scene renders it (unevaluable), as warnings.
MISSING_IMAGES = ("no pixels in {images} (read by {materials}): missing files? Cycles shows "
                  "them magenta and Luxel bakes them so; find them (File > External Data > "
                  "Find Missing Files) or remove their nodes")
RAY_KIND = ("{materials} ({nodes}) depend on the kind of ray; Luxel evaluates them as a "
            "camera ray sees them")
OBJECT_DATA = ("{materials} ({nodes}) read the object, its instancer or the view layer; Luxel "
               "evaluates them on a copy of the mesh, where these read their defaults")
# Nodes whose output does not vary over a surface unless something that does feeds them.
_VARYING_PREFIXES = ("ShaderNodeTex",)
_VARYING = {"ShaderNodeTexCoord", "ShaderNodeUVMap", "ShaderNodeAttribute",
            "ShaderNodeVertexColor", "ShaderNodeNewGeometry", "ShaderNodeObjectInfo",
            "ShaderNodeParticleInfo", "ShaderNodeHairInfo", "ShaderNodePointInfo",
            "ShaderNodeTangent", "ShaderNodeFresnel", "ShaderNodeLayerWeight",
            "ShaderNodeWireframe", "ShaderNodeBevel", "ShaderNodeAmbientOcclusion",
            "ShaderNodeLightPath", "ShaderNodeCameraData", "ShaderNodeScript",
            "ShaderNodeNormalMap", "ShaderNodeBump", "ShaderNodeDisplacement"}
_EMITTERS = {"ShaderNodeEmission", "ShaderNodeBackground"}


def may_emit(material):
    """Whether ``material`` may emit light anywhere: an Emission node, or a Principled BSDF
    whose emission strength is wired or not 0 (Cycles' negative values are warned of),
    feeds its output (through any nodes, node groups included). Cycles measures how much
    (EMIT); this only decides, before the atlas is charted, which triangles are emitters
    (they shoot from a copy of their back too)."""
    output = user_output(material)
    return output is not None and any(
        node.bl_idname in _EMITTERS or (
            node.bl_idname == 'ShaderNodeBsdfPrincipled'
            and (node.inputs["Emission Strength"].is_linked
                 or node.inputs["Emission Strength"].default_value != 0.0))
        for node in upstream(output))


def user_output(material):
    """The material's active Cycles output, the user's own while Luxel's display shows."""
    tree = material.node_tree
    if tree is None:
        return None
    if STATE_KEY in material:
        return tree.nodes.get(material[STATE_KEY]["output"])
    outputs = [n for n in tree.nodes if n.bl_idname == 'ShaderNodeOutputMaterial']
    for node in outputs:
        if node.is_active_output and getattr(node, "target", "ALL") in ('ALL', 'CYCLES'):
            return node
    return outputs[0] if outputs else None


def upstream(node, seen=None):
    """Every node that feeds ``node`` (itself included), inside node groups too."""
    seen = set() if seen is None else seen
    found = []
    stack = [node]
    while stack:
        node = stack.pop()
        if node.as_pointer() in seen or node.name.startswith(NODE_PREFIX):
            continue
        seen.add(node.as_pointer())
        found.append(node)
        if node.bl_idname == 'ShaderNodeGroup' and node.node_tree is not None:
            outputs = [n for n in node.node_tree.nodes if n.bl_idname == 'NodeGroupOutput']
            for output in outputs:
                found += upstream(output, seen)
        for socket in node.inputs:
            stack += [link.from_node for link in socket.links if link.is_valid]
    return found


def varies(material):
    """Whether a material's result may vary over a surface (it reads a texture, coordinates,
    attributes, geometry or the view): materials.py bakes such materials at more samples."""
    output = user_output(material)
    return output is not None and any(
        node.bl_idname in _VARYING or node.bl_idname.startswith(_VARYING_PREFIXES)
        for node in upstream(output))


def unevaluable(material):
    """(problem, subject) for what a bake of the material's copy on a copy of its mesh cannot
    give as the scene renders it: the problem a warning's text, with {images} or {nodes}
    (the subjects) and {materials} to fill in."""
    output = user_output(material)
    for node in [] if output is None else upstream(output):
        if (node.bl_idname == 'ShaderNodeTexImage' and node.image is not None
                and 0 in node.image.size):
            yield MISSING_IMAGES, node.image.name
        elif node.bl_idname == 'ShaderNodeLightPath':
            yield RAY_KIND, node.name
        elif node.bl_idname == 'ShaderNodeObjectInfo' or (
                node.bl_idname == 'ShaderNodeAttribute'
                and node.attribute_type in {'OBJECT', 'INSTANCER', 'VIEW_LAYER'}):
            yield OBJECT_DATA, node.name
