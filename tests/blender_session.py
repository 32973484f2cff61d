"""The bpy module with Luxel enabled as a development extension (see tools/blender.py), once
per test process, and a fresh empty file for each test."""
from pathlib import Path
import sys

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tools"))
import blender as runner  # noqa: E402  (tools/blender.py, found through the path above)

MODULE = runner.MODULE
ROOT = runner.ROOT
_bpy = None


def blender():
    global _bpy
    if _bpy is None:
        _bpy = runner.start_blender()
    return _bpy


def addon():
    return runner.luxel()


def empty_file():
    """An empty file rendering with Cycles under a black world (a new world is grey)."""
    bpy = blender()
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = 'CYCLES'
    world = bpy.data.worlds.new("World")
    world.color = (0.0, 0.0, 0.0)
    if world.node_tree is None:         # Blender before 5.0 makes it on use_nodes
        world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    scene.world = world
    return scene
