"""The extension zip as users get it: tools/build_extension.py builds it (the wheels are cached in
dist/wheels/, downloaded from PyPI on the first run), tools/check_extension_install.py installs it
into a fresh Blender profile, with the venv's moderngl, glcontext, xatlas and OpenEXR hidden, and
bakes a small room with it."""
import importlib.util
from pathlib import Path
import re
import subprocess
import sys
import tomllib
import zipfile

import pytest

ROOT = Path(__file__).resolve().parent.parent
BUNDLED = ("moderngl", "glcontext", "xatlas", "OpenEXR", "flip_evaluator")
PLATFORM_TAGS = {"linux-x64": "manylinux", "windows-x64": "win_amd64",
                 "macos-arm64": "macosx_11_0_arm64"}
PYTHON_TAGS = ("cp311", "cp313")  # Blender 4.2 to 5.0; 5.1 and 5.2


def run(*arguments):
    result = subprocess.run([sys.executable, *map(str, arguments)], cwd=ROOT,
                            capture_output=True, text=True)
    output = result.stdout + result.stderr
    assert result.returncode == 0, output
    return output


@pytest.mark.skipif(importlib.util.find_spec("bpy") is None, reason="needs the bpy module")
def test_built_zip_installs_with_its_wheels_and_bakes(tmp_path):
    run(ROOT / "tools" / "build_extension.py", "--output", tmp_path)
    (target,) = tmp_path.glob("luxel-*.zip")

    with zipfile.ZipFile(target) as archive:
        names = archive.namelist()
        manifest = tomllib.loads(archive.read("blender_manifest.toml").decode())
    assert not [name for name in names
                if name.split("/")[0] in ("tests", "sample_blends", "bench", "tools")]
    assert set(manifest["platforms"]) == set(PLATFORM_TAGS)
    assert len(manifest["wheels"]) == len(PLATFORM_TAGS) * len(PYTHON_TAGS) * len(BUNDLED)
    for platform, tag in PLATFORM_TAGS.items():
        for python in PYTHON_TAGS:
            wheels = [path for path in manifest["wheels"] if tag in path and f"-{python}-" in path]
            assert sorted(re.match(r"\./wheels/([^-]+)-", path)[1] for path in wheels) == sorted(
                name.lower() for name in BUNDLED), (platform, python)

    output = run(ROOT / "tools" / "check_extension_install.py", target)
    if any(importlib.util.find_spec(name) for name in BUNDLED):  # the venv's copies are hidden
        assert "isolated: python -S" in output
    for name in BUNDLED:  # paths relative to the profile's extension site-packages
        assert re.search(rf"^{name}: lib/python3\.\d+/site-packages/", output, re.MULTILINE)
    assert re.search(r"^bake: [\d,]+ texels, \d+ shots", output, re.MULTILINE), output
    assert "installs, enables, finds its dependencies in the wheels and bakes" in output
