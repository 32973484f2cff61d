"""What the benchmark scripts share: the command line, the result files and the sample scenes.

Every study script takes the same command line:

    python bench/SCRIPT.py STUDY [--device {cpu,gpu}] [--quick] [--out DIR] [--dry-run]

--device picks the sizes (cpu: what a 2-core CPU with llvmpipe finishes within minutes; gpu:
the paper's sizes, about a million texels), --quick a smoke size of a few seconds, --out the
folder of the result files (bench/results), --dry-run prints the sizes without running.
A study writes DIR/STUDY.json: one entry per device (a GPU run leaves the CPU run in place),
each with the commit, the date, the OpenGL renderer, the command line, the wall time and
the study's own results. bench/run.py runs every study; bench/report.py turns the files
into BENCHMARKS.md's tables and bench/results/STUDY.png."""
import argparse
import dataclasses
import datetime
import json
import math
import os
from pathlib import Path
import re
import shlex
import subprocess
import sys
import time
from typing import Callable

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from native import Scene  # noqa: E402  (found through the path above)
from native.gpu import using  # noqa: E402

RESULTS = ROOT / "bench" / "results"
NUMBER_LIST = re.compile(r"\[\s*((?:-?[\d.eE+-]+,?\s*)+)\]")
SCENES = ROOT / "bench" / "scenes"
DEVICES = ("cpu", "gpu")
# The quad whose side the paper's per-triangle texture "size" is measured against: the size is
# the number of texels across it (see texel_density_for_size).
REFERENCE_QUAD = {"columns": "floor", "cornell_box": "back_wall"}


@dataclasses.dataclass(frozen=True)
class Study:
    """One measurement, its result file bench/results/<name>.json. ``measure`` takes the
    keyword arguments of one of ``sizes`` ("quick", "cpu", "gpu") and returns the results
    (JSON-able); ``blender``: it needs the bpy module."""
    name: str
    measure: Callable[..., dict]
    sizes: dict
    blender: bool = False

    def size(self, device, *, quick):
        return self.sizes["quick" if quick else device]


def arguments(description, studies=None):
    """The shared command line; ``studies`` (a study script's) adds the STUDY argument."""
    parser = argparse.ArgumentParser(description=description)
    if studies is not None:
        parser.add_argument("study", choices=[study.name for study in studies])
    parser.add_argument("--device", choices=DEVICES, default="cpu",
                        help="the sizes to run: cpu (llvmpipe, 2 cores) or gpu (the paper's)")
    parser.add_argument("--quick", action="store_true", help="smoke sizes: seconds")
    parser.add_argument("--out", type=Path, default=RESULTS, help="folder of STUDY.json")
    parser.add_argument("--dry-run", action="store_true", help="print the plan, run nothing")
    return parser


def main(description, studies):
    """A study script's entry point: runs the study its command line names."""
    args = arguments(description, studies).parse_args()
    study = next(study for study in studies if study.name == args.study)
    size = study.size(args.device, quick=args.quick)
    print(plan_line(study, args.device, size), flush=True)
    if args.dry_run:
        return
    device = gl_renderer()
    if args.device == "gpu" and "llvmpipe" in device:
        sys.exit(f"{study.name}: --device gpu, but OpenGL renders with {device}")
    started = time.perf_counter()
    results = study.measure(**size)
    write_results(args.out / f"{study.name}.json", args.device, {
        "commit": commit(), "date": datetime.date.today().isoformat(), "device": device,
        "cpu_cores": os.cpu_count(), "quick": args.quick,
        "command": shlex.join(["python", *relative_argv()]),
        "wall_seconds": time.perf_counter() - started, "size": size, "results": results})
    if study.blender:
        os._exit(0)     # bpy's teardown after a bake can crash on some versions


def plan_line(study, device, size):
    shown = ", ".join(f"{key}={value}" for key, value in size.items())
    return f"{study.name} ({device}{', needs bpy' if study.blender else ''}): {shown}"


def relative_argv():
    """The command line with paths inside the repository relative to its root, as anyone
    would type it there."""
    def relative(argument):
        path = Path(argument)
        if path.is_absolute() and path.resolve().is_relative_to(ROOT):
            return str(path.resolve().relative_to(ROOT))
        return argument
    return [relative(str(Path(sys.argv[0]).resolve())), *map(relative, sys.argv[1:])]


def commit():
    """The short commit, with "-dirty" when what runs (the code, result files and the
    documents aside) differs from it."""
    def git(*args):
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True,
                              text=True).stdout.strip()
    changed = git("status", "--porcelain", "--", ".", ":(exclude)bench/results",
                  ":(exclude)*.md", ":(exclude)docs")
    return git("rev-parse", "--short", "HEAD") + ("-dirty" if changed else "")


def gl_renderer():
    """The OpenGL renderer and version, read in a process of its own: a study that runs
    Blender must not have made a GL context before it (see the Makefile's test target)."""
    probe = "\n".join(["from native import create_context",
                       "from native.gpu import using",
                       "ctx = create_context()",
                       "with using(ctx):",
                       "    print(ctx.info['GL_RENDERER'], '/', ctx.info['GL_VERSION'])"])
    done = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, capture_output=True,
                          text=True)
    lines = done.stdout.strip().splitlines()
    return lines[-1] if done.returncode == 0 and lines else "no OpenGL"


def device_name(ctx):
    """Renderer and OpenGL version. moderngl reads ctx.info once and keeps it, so it has to be
    read with the context current (the solver's memory check uses it too)."""
    with using(ctx):
        return f"{ctx.info['GL_RENDERER']} / {ctx.info['GL_VERSION']}"


def write_results(path, device, run):
    """Put ``run`` into the study's file as its ``device`` entry, keeping the other device's."""
    path.parent.mkdir(parents=True, exist_ok=True)
    study = json.loads(path.read_text()) if path.exists() else {"study": path.stem, "runs": {}}
    study["runs"][device] = run
    text = json.dumps(plain(study), indent=1, allow_nan=False)
    # A list of numbers on one line: a curve of thousands of points is not thousands of lines.
    text = NUMBER_LIST.sub(lambda match: "[" + ", ".join(
        number.strip(",") for number in match[1].split()) + "]", text)
    path.write_text(text + "\n")
    print(f"wrote {path}", flush=True)


def plain(value):
    """JSON's own kinds: numpy scalars and arrays as numbers and lists, NaN and infinity as
    None."""
    if isinstance(value, dict):
        return {str(key): plain(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(item) for item in value]
    if isinstance(value, np.ndarray):
        return plain(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def start_blender():
    """bpy with Luxel enabled as a development extension (tools/blender.py), and Luxel's
    package as Blender imported it."""
    sys.path.insert(0, str(ROOT / "tools"))
    import blender      # tools/blender.py, found through the path above
    return blender.start_blender(), blender.luxel()


def open_blend(bpy, name):
    bpy.ops.wm.open_mainfile(filepath=str(ROOT / "sample_blends" / f"{name}.blend"))


def load_scene(name):
    """A sample scene exported by bench/export_scenes.py (no Blender needed)."""
    return Scene.load(SCENES / f"{name}.npz")


def reference_side(scene, name):
    """Side in metres of the square with the area of the scene's reference quad: the Cornell
    box's back wall (0.55 m), the columns' floor (8 m)."""
    quad = scene.object_names.index(REFERENCE_QUAD[name])
    return math.sqrt(float(scene.triangle_area[scene.object_index == quad].sum()))


def texel_density_for_size(scene, name, size):
    """Texels per metre that put ``size`` texels across the reference quad, the way a
    size x size texture covers one of the paper's quads."""
    return size / reference_side(scene, name)


def narrowest_object(scene):
    """Metres: the smallest, over the objects with texels, of the second-smallest side of the
    object's bounding box (a flat quad's narrow side, a column's width)."""
    from native.atlas import charted_triangles
    charted = charted_triangles(scene)
    sides = []
    for index in np.unique(scene.object_index[charted]):
        corners = scene.vertices[scene.triangles[charted & (scene.object_index == index)]]
        extent = np.ptp(corners.reshape(-1, 3), axis=0)
        sides.append(np.sort(extent)[1])
    return float(min(sides))


def shoot_level_for(scene, density):
    """The coarsest mip level whose blocks are no wider than the narrowest object. The paper
    shot from each triangle's own texture; an atlas block wider than an object lumps texels of
    differently facing charts into one shooter, which sends their light the wrong way (about
    30 % too much light on the columns' floor, measured with blocks of 2 m)."""
    return int(min(max(math.floor(math.log2(narrowest_object(scene) * density)), 0), 6))

