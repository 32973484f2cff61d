"""Blender's lights and world as the solver takes them, in Cycles' units: point, spot and sun
lights as native lights, an area light as a fan of emitting triangles of its shape, the world
as its Background node's uniform colour. What cannot be mapped is approximated and reported
through ``warn`` (a function of the message)."""
from dataclasses import dataclass
import math

import numpy as np

from ..native import PointLight, SceneError, SpotLight, SunLight

DISK_SEGMENTS = 32


@dataclass
class AreaLight:
    """An area light as triangles around its centre, their fronts facing the light's -Z, where
    it shines, each emitting ``radiance`` (RGB)."""
    name: str
    vertices: np.ndarray    # (V, 3) world positions: the centre, then the outline
    triangles: np.ndarray   # (T, 3)
    normal: np.ndarray      # (3,)
    radiance: np.ndarray    # (3,)


def light_of(obj, matrix, warn):
    """The light of a Blender light object at ``matrix`` (its world matrix, 4 x 4): a
    PointLight, SpotLight, SunLight or AreaLight, or None where it gives no light."""
    light = obj.data
    name = obj.original.name
    colour = np.array(light.color[:3], dtype=np.float64)
    if getattr(light, "use_temperature", False):
        colour = colour * np.array(light.temperature_color[:3])
    power = float(light.energy) * 2.0 ** float(getattr(light, "exposure", 0.0))
    if power < 0.0:
        warn(f"light '{name}' has a negative power and is left out (light cannot be "
             "negative); set its power to 0 or more")
    if power <= 0.0 or colour.max() <= 0.0:
        return None
    position = matrix[:3, 3]
    direction = -matrix[:3, 2]
    direction = direction / np.linalg.norm(direction)
    if light.type == 'POINT':
        return PointLight(tuple(position), power, tuple(colour), name)
    if light.type == 'SPOT':
        if light.use_square:
            warn(f"light '{name}': square spots are baked as round cones")
        return SpotLight(tuple(position), power, tuple(colour), name, tuple(direction),
                         float(light.spot_size), float(light.spot_blend))
    if light.type == 'SUN':
        return SunLight(tuple(direction), power, tuple(colour), name)
    if light.type == 'AREA':
        return _area_light(light, name, matrix, power, colour, warn)
    return None


def _area_light(light, name, matrix, power, colour, warn):
    if light.spread < math.pi - 1e-4:
        warn(f"light '{name}': a spread below 180 degrees is baked as 180")
    if not getattr(light, "normalize", True):
        warn(f"light '{name}': 'Normalize' off is baked as on (power spread over the light's "
             "area)")
    half_x = 0.5 * light.size
    half_y = 0.5 * (light.size_y if light.shape in ('RECTANGLE', 'ELLIPSE') else light.size)
    if light.shape in ('DISK', 'ELLIPSE'):
        angles = 2.0 * math.pi * np.arange(DISK_SEGMENTS) / DISK_SEGMENTS
        outline = np.column_stack([half_x * np.cos(angles), half_y * np.sin(angles)])
    else:
        outline = np.array([[-half_x, -half_y], [half_x, -half_y], [half_x, half_y],
                            [-half_x, half_y]])
    local = np.column_stack([outline, np.zeros(len(outline))])
    vertices = np.vstack([np.zeros(3), local]) @ matrix[:3, :3].T + matrix[:3, 3]
    count = len(outline)
    # Clockwise seen from +Z, so the front faces the light's -Z, where it shines.
    triangles = np.array([[0, (i + 1) % count + 1, i + 1] for i in range(count)])
    corners = vertices[triangles]
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                         corners[:, 2] - corners[:, 0]), axis=1).sum()
    if area <= 0.0:
        raise SceneError(f"area light '{name}' has zero size; give it a size above 0", name)
    return AreaLight(name, vertices, triangles,
                     normal=-matrix[:3, 2] / np.linalg.norm(matrix[:3, 2]),
                     radiance=power * colour / (math.pi * area))


def sky_of(world, warn):
    """The world's light as the solver's uniform sky (RGB radiance): its Background node's
    colour times strength, the viewport colour where it has no node tree or another shader,
    black without a world."""
    if world is None:
        return (0.0, 0.0, 0.0)
    tree = world.node_tree
    output = _active_output(tree, 'ShaderNodeOutputWorld') if tree else None
    if output is None:
        return tuple(world.color)
    if not output.inputs["Surface"].is_linked:
        return (0.0, 0.0, 0.0)
    node = output.inputs["Surface"].links[0].from_node
    if node.bl_idname != 'ShaderNodeBackground':
        warn(f"world '{world.name}': only a Background node is read; the world is baked as "
             "its viewport colour")
        return tuple(world.color)
    colour, strength = node.inputs["Color"], node.inputs["Strength"]
    if colour.is_linked or strength.is_linked:
        warn(f"world '{world.name}': a textured or sky world is baked as the Background "
             "node's own uniform colour")
    return tuple(np.maximum(np.array(colour.default_value[:3]) *
                            float(strength.default_value), 0.0))


def _active_output(tree, idname):
    outputs = [n for n in tree.nodes if n.bl_idname == idname]
    for node in outputs:
        if node.is_active_output and getattr(node, "target", "ALL") in ('ALL', 'CYCLES'):
            return node
    return outputs[0] if outputs else None
