"""`blender -b FILE.blend --command luxel ARGS` for machines that have Blender as the bpy module
(pip install bpy) rather than the blender program:

    python tools/blender.py -b sample_blends/cornell_box.blend --command luxel bake --output out

It takes the part of Blender's command line that bakes use, in Blender's order: `-b`, `-y` /
`--enable-autoexec`, `-Y` / `--disable-autoexec`, `--factory-startup`, the .blend file,
`--python-exit-code N`, `--python-expr CODE`, `-P` / `--python FILE`, and `--command` with
everything after it (what a render farm's Blender command lines hold). Luxel is loaded the
way Blender loads an extension under development: the repo root linked as
<user extensions>/user_default/luxel and enabled as bl_ext.user_default.luxel. Blender's user
folders go to a temporary directory, so the user's own preferences are never read or changed.
"""
import importlib
import os
from pathlib import Path
import sys
import tempfile
import traceback

ROOT = Path(__file__).resolve().parent.parent
MODULE = "bl_ext.user_default.luxel"
USAGE = ("usage: blender.py -b [-y] FILE.blend [--python-exit-code N] [--python-expr CODE] "
         "[--python FILE] --command luxel ARGS")
# Switches that change nothing here: the bpy module runs in the background, with Python
# scripts allowed, from its factory settings.
IGNORED = {"-b", "--background", "-y", "--enable-autoexec", "-Y", "--disable-autoexec",
           "--factory-startup"}
EXIT_USAGE = 2


class CommandLineError(Exception):
    pass


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


def parse(argv):
    """Blender's arguments in order, as (action, value) pairs: ("open", FILE),
    ("exit_code", N), ("python_expr", CODE), ("python", FILE), ("command", [ARGS])."""
    actions, rest = [], list(argv)
    while rest:
        argument = rest.pop(0)
        if argument in IGNORED:
            continue
        if argument == "--command":
            if not rest or rest[0] != "luxel":
                raise CommandLineError("only the luxel command is provided here: "
                                       "--command luxel ...")
            actions.append(("command", rest[1:]))
            return actions
        if argument in ("--python-exit-code", "--python-expr", "--python", "-P"):
            if not rest:
                raise CommandLineError(f"{argument} needs a value")
            value = rest.pop(0)
            if argument == "--python-exit-code":
                if not value.isdigit() or int(value) > 255:
                    raise CommandLineError(f"--python-exit-code {value}: give 0 to 255")
                actions.append(("exit_code", int(value)))
            else:
                actions.append(("python_expr" if argument == "--python-expr" else "python",
                                value))
        elif argument.startswith("-"):
            raise CommandLineError(f"{argument} is not taken here")
        else:
            actions.append(("open", argument))
    raise CommandLineError("--command luxel ... is missing")


def main(argv):
    try:
        actions = parse(argv)
    except CommandLineError as error:
        print(f"{USAGE}\nblender.py: {error}", file=sys.stderr)
        return EXIT_USAGE
    bpy = start_blender()
    exit_code = 0
    for action, value in actions:
        if action == "open":
            path = Path(value).resolve()
            try:
                bpy.ops.wm.open_mainfile(filepath=str(path))
            except RuntimeError as error:
                reason = str(error).strip().removeprefix("Error:").strip()
                print(f"blender.py: cannot open '{path}': {reason}", file=sys.stderr)
                return 1
        elif action == "exit_code":
            exit_code = value
        elif action in ("python_expr", "python"):
            try:
                if action == "python_expr":
                    exec(compile(value, "<string>", "exec"), {"__name__": "__main__"})
                else:
                    source = Path(value).read_text()
                    exec(compile(source, value, "exec"), {"__name__": "__main__",
                                                          "__file__": value})
            except Exception:   # as Blender does: the traceback, then stop or go on
                traceback.print_exc()
                if exit_code:
                    return exit_code
        else:
            return luxel().addon.cli.execute(value)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
