"""The bpy module with Luxel loaded the way Blender loads an extension under development:
the repo root linked as <user extensions>/user_default/luxel, enabled as
bl_ext.user_default.luxel. Blender's user folders go to a temporary directory so the tests
never read or write the user's own preferences."""
import os
from pathlib import Path
import tempfile

ROOT = Path(__file__).resolve().parent.parent
MODULE = "bl_ext.user_default.luxel"

_bpy = None


def blender():
    """Import bpy once per process, with Luxel enabled."""
    global _bpy
    if _bpy is None:
        os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="luxel-blender-")
        import bpy
        repo = Path(bpy.utils.user_resource('EXTENSIONS', path="user_default", create=True))
        (repo / "luxel").symlink_to(ROOT)
        bpy.ops.preferences.addon_enable(module=MODULE)
        _bpy = bpy
    return _bpy


def addon():
    """Luxel's package as Blender imported it."""
    import importlib
    return importlib.import_module(MODULE)


def empty_file():
    bpy = blender()
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = 'CYCLES'
    world = bpy.data.worlds.new("World")
    world.color = (0.0, 0.0, 0.0)
    background = world.node_tree.nodes.get("Background")
    background.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    scene.world = world
    return scene
