"""Shared by the benchmark scripts: import path, result files and the exported sample scenes."""
import json
import math
from pathlib import Path
import sys

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from native import Scene  # noqa: E402  (found through the path above)
from native.atlas import charted_triangles  # noqa: E402
from native.gpu import using  # noqa: E402

SCENES = ROOT / "bench" / "scenes"
# The quad whose side the paper's per-triangle texture "size" is measured against: the size is
# the number of texels across it (see texel_density_for_size).
REFERENCE_QUAD = {"columns": "floor", "cornell_box": "back_wall"}


def save_results(path, payload):
    """Write one run's results as JSON (bench/plot.py reads them)."""
    if path is None:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(payload, indent=1))


def add_level_arguments(parser, density):
    """The options of the benchmarks that bake a real level: which, where, and how far."""
    parser.add_argument("--levels", type=Path, required=True, help="folder of LEVEL.obj")
    parser.add_argument("--level", required=True)
    parser.add_argument("--density", type=float, default=density)
    parser.add_argument("--threshold", type=float, default=0.01)
    parser.add_argument("--shots", type=int, default=0, help="shot limit; 0: automatic")


def device_name(ctx):
    """Renderer and OpenGL version. moderngl reads ctx.info once and keeps it, so it has to be
    read with the context current (the solver's memory check uses it too)."""
    with using(ctx):
        return f"{ctx.info['GL_RENDERER']} / {ctx.info['GL_VERSION']}"


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
