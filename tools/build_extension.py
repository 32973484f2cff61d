"""Builds the installable extension zip, dist/luxel-<version>.zip: the add-on, the solver, the
shaders, the browser viewer with its three.js and the dependency wheels of every supported
platform, with the manifest naming them.

    python tools/build_extension.py [--output DIR] [--wheel-cache DIR]
"""
import argparse
import json
from pathlib import Path
import re
import subprocess
import sys
import tomllib
import zipfile

ROOT = Path(__file__).resolve().parent.parent
MANIFEST = "blender_manifest.toml"
PYTHON_VERSIONS = ("3.11", "3.13")  # Blender 4.2 to 5.0 bundle CPython 3.11, 5.1 and 5.2 3.13
PROVIDED_BY_BLENDER = {"numpy"}  # Blender's own numpy; a second copy would shadow it
# Blender platform -> pip platform tags. Blender's Linux builds need glibc 2.28, so any older
# manylinux wheel fits; pip widens macosx_11_0_arm64 to older macOS and universal2 itself.
# No macos-x64: Blender 4.5 was the last for Intel Macs, and moderngl 5.13.0, glcontext 3.1.0
# and flip-evaluator 1.7 publish no x86_64 macOS wheels (their last: 5.12.0, 3.0.0, 1.6.0.1).
PLATFORMS = {
    "linux-x64": [f"manylinux_2_{minor}_x86_64" for minor in range(28, 4, -1)]
                 + ["manylinux2014_x86_64", "manylinux2010_x86_64", "manylinux1_x86_64"],
    "windows-x64": ["win_amd64"],
    "macos-arm64": ["macosx_11_0_arm64"],
}


def read_pins(requirements):
    """The exact pins of requirements.txt, less the packages Blender provides."""
    pins = []
    for line in requirements.read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        match = re.fullmatch(r"([A-Za-z0-9][A-Za-z0-9._-]*)==(\S+)", line)
        if not match:
            sys.exit(f"{requirements.name}: {line!r} is not an exact pin (name==version)")
        if match[1].lower() not in PROVIDED_BY_BLENDER:
            pins.append((match[1], match[2]))
    return pins


def cached_wheel(folder, name, version, python):
    """The wheel of name==version for CPython python ("3.11") in folder, or None. Wheel names
    are normalized to lower case with underscores (OpenEXR -> openexr)."""
    prefix = f"{re.sub(r'[-_.]+', '_', name).lower()}-{version}-{cpython(python)}-"
    matches = sorted(path for path in folder.glob("*.whl") if path.name.lower().startswith(prefix))
    return matches[0] if matches else None


def cpython(python):
    return "cp" + python.replace(".", "")


def fetch_wheels(cache, pins):
    """One wheel per pin, platform and Python version, downloaded into cache/<platform>/ unless
    already there."""
    wheels = {}
    for platform, tags in PLATFORMS.items():
        folder = cache / platform
        wheels[platform] = []
        for python in PYTHON_VERSIONS:
            missing = [f"{name}=={version}" for name, version in pins
                       if cached_wheel(folder, name, version, python) is None]
            if missing:
                download(folder, platform, tags, python, missing)
            for name, version in pins:
                wheel = cached_wheel(folder, name, version, python)
                if wheel is None:
                    sys.exit(f"no CPython {python} wheel of {name}=={version} for {platform} "
                             f"in {folder}")
                wheels[platform].append(wheel)
    return wheels


def download(folder, platform, tags, python, requirements):
    command = [sys.executable, "-m", "pip", "download", "--quiet", "--dest", str(folder),
               "--only-binary=:all:", "--no-deps", "--python-version", python,
               "--implementation", "cp", "--abi", cpython(python)]
    for tag in tags:
        command += ["--platform", tag]
    result = subprocess.run(command + requirements, capture_output=True, text=True)
    if result.returncode != 0:
        # pip's last ERROR line names the requirement it could not satisfy.
        errors = [line for line in result.stderr.splitlines() if line.startswith("ERROR")]
        reason = errors[-1] if errors else result.stderr.strip()
        sys.exit(f"pip found no CPython {python} wheel for {platform} "
                 f"(tags {tags[0]}...): {reason}")


def ships(path):
    """Whether a repository-relative path belongs in the extension zip."""
    parts = path.split("/")
    if any(part.startswith(".") or part == "__pycache__" for part in parts) or path.endswith(".md"):
        return False
    if len(parts) == 1:
        return path in ("__init__.py", "LICENSE")
    if parts[0] in ("addon", "native"):
        return path.endswith(".py")
    if parts[0] == "viewer":
        return path == "viewer/package.json" or path in viewer_files()
    return parts[0] == "shaders"


def viewer_files():
    """The viewer page's files (viewer/package.json's pageFiles)."""
    return [f"viewer/{name}" for name in _viewer_listing()["pageFiles"]]


def three_files():
    """three.js's files the viewer page imports (threeFiles), from viewer/node_modules: npm
    installs them (make viewer), git does not track them."""
    paths = [f"viewer/node_modules/three/{name}" for name in _viewer_listing()["threeFiles"]]
    if missing := [path for path in paths if not (ROOT / path).is_file()]:
        sys.exit(f"{missing[0]} is missing: run `make viewer` first")
    return paths


def _viewer_listing():
    return json.loads((ROOT / "viewer" / "package.json").read_text())


def git_files(*options):
    listing = subprocess.run(["git", "ls-files", "-z", *options], cwd=ROOT, capture_output=True,
                             text=True, check=True).stdout
    return [path for path in listing.split("\0") if path and ships(path)]


def source_files():
    """Repository-relative paths to ship: git's tracked and not-ignored files when git knows the
    tree (so ignored build output never ships), otherwise every file under the root."""
    try:
        tracked = git_files()
        untracked = git_files("--others", "--exclude-standard")
    except (OSError, subprocess.CalledProcessError):
        return sorted(path for path in (p.relative_to(ROOT).as_posix() for p in ROOT.rglob("*"))
                      if ships(path) and (ROOT / path).is_file())
    if untracked:
        print(f"warning: shipping {len(untracked)} files git does not track yet: "
              + ", ".join(sorted(untracked)))
    # A tracked file deleted from the work tree is still in git's index.
    return sorted(path for path in tracked + untracked if (ROOT / path).is_file())


def packaged_manifest(text, wheel_paths):
    """The manifest with the wheels and platforms keys added at the top level, that is before the
    first table; the repository's own manifest has neither, since the venv serves development."""
    if {"wheels", "platforms"} & tomllib.loads(text).keys():
        sys.exit(f"{MANIFEST} must not list wheels or platforms: the build adds them")
    lines = ["wheels = ["] + [f'  "{path}",' for path in wheel_paths] + ["]"]
    lines.append("platforms = [" + ", ".join(f'"{name}"' for name in PLATFORMS) + "]")
    block = "\n".join(lines) + "\n\n"
    table = re.search(r"^\[", text, re.MULTILINE)
    at = table.start() if table else len(text)
    return text[:at] + block + text[at:]


def write_zip(target, manifest, files, wheels):
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr(MANIFEST, manifest)
        for path in files:
            archive.write(ROOT / path, path)
        for wheel in wheels:  # already compressed
            archive.write(wheel, f"wheels/{wheel.name}", compress_type=zipfile.ZIP_STORED)


def validate(target):
    """Re-reads the zip: the manifest parses; __init__.py and every wheel it lists are inside."""
    with zipfile.ZipFile(target) as archive:
        names = set(archive.namelist())
        manifest = tomllib.loads(archive.read(MANIFEST).decode())
    required = {"__init__.py"} | {path.removeprefix("./") for path in manifest["wheels"]}
    if missing := sorted(required - names):
        sys.exit(f"{target} is incomplete, missing: {', '.join(missing)}")
    return len(names)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", type=Path, default=ROOT / "dist", help="zip folder")
    parser.add_argument("--wheel-cache", type=Path, default=ROOT / "dist" / "wheels",
                        help="downloaded wheels, kept between builds")
    args = parser.parse_args()

    manifest_text = (ROOT / MANIFEST).read_text()
    manifest = tomllib.loads(manifest_text)
    wheels = fetch_wheels(args.wheel_cache, read_pins(ROOT / "requirements.txt"))
    for platform, files in wheels.items():
        print(f"{platform}: " + ", ".join(wheel.name for wheel in files))
    all_wheels = [wheel for files in wheels.values() for wheel in files]

    args.output.mkdir(parents=True, exist_ok=True)
    target = args.output / f"{manifest['id']}-{manifest['version']}.zip"
    packaged = packaged_manifest(manifest_text, [f"./wheels/{wheel.name}" for wheel in all_wheels])
    write_zip(target, packaged, source_files() + three_files(), all_wheels)
    count = validate(target)
    print(f"{target}: {target.stat().st_size / 1e6:.1f} MB, {count} files")


if __name__ == "__main__":
    main()
