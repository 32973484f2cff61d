"""`blender -b FILE.blend --command luxel ARGS` for machines that have Blender as the bpy module
(pip install bpy) rather than the blender program:

    python tools/blender.py -b sample_blends/cornell_box.blend --command luxel bake --output out

Luxel is loaded the way Blender loads an extension under development: the repo root linked as
<user extensions>/user_default/luxel and enabled as bl_ext.user_default.luxel. Blender's user
folders go to a temporary directory, so the user's own preferences are never read or changed.
"""
import argparse
import importlib
import os
from pathlib import Path
import sys
import tempfile

ROOT = Path(__file__).resolve().parent.parent
MODULE = "bl_ext.user_default.luxel"


def start_blender():
    """Import bpy with a private user profile and Luxel enabled; returns bpy."""
    if "bpy" in sys.modules:
        raise RuntimeError("bpy was imported before start_blender(): Blender has already "
                           "chosen its user folders")
    os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="luxel-blender-")
    import bpy
    repo = Path(bpy.utils.user_resource('EXTENSIONS', path="user_default", create=True))
    (repo / "luxel").symlink_to(ROOT)
    bpy.ops.preferences.addon_enable(module=MODULE)
    return bpy


def luxel():
    """Luxel's package as Blender imported it."""
    return importlib.import_module(MODULE)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("-b", "--background", metavar="FILE.blend", required=True)
    parser.add_argument("--command", nargs=argparse.REMAINDER, required=True,
                        help="luxel followed by its arguments")
    args = parser.parse_args(argv)
    if not args.command or args.command[0] != "luxel":
        parser.error("only the luxel command is provided here: --command luxel ...")
    bpy = start_blender()
    bpy.ops.wm.open_mainfile(filepath=str(Path(args.background).resolve()))
    return luxel().addon.cli.execute(args.command[1:])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
