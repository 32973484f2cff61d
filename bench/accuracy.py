"""Luxel against Cycles (needs the bpy module; bench/common.py has the command line):

    python bench/accuracy.py equal-error        # time to 5, 2 and 1 % relative RMS, both
    python bench/accuracy.py cornell-defaults   # the Cornell box at the defaults, per object
    python bench/accuracy.py interior           # the realistic interior, per shown copy
    python bench/accuracy.py materials          # what Cycles' material bakes cost
    python bench/accuracy.py glossy-furnace     # what a Principled BSDF reflects, both

Errors are measured alike for both renderers, two ways: per texel, Cycles baking into Luxel's
lightmap UVs texel for texel (the paper's eq. 1 over the texels both cover), and at points on
the surfaces, each lightmap looked up as a renderer filters it (SurfaceMeasure). A reference is
two Cycles bakes with different seeds, averaged; a quarter of the mean squared difference of
the two is the average's noise variance, which is taken out of every squared error
("debiased"), so that an error measures the distance to the converged answer rather than to
the reference's noise. Luxel's seconds are its bake through the extension from the operator's
start (export, materials, atlas, shots; its lightmap snapshots not counted), Cycles' each
bake call (scene sync included); both warm: an untimed Luxel bake of the scene comes first
(warm_up()), as the reference's bakes come before Cycles' timed ones."""
import dataclasses
import math
import statistics
import time

import numpy as np

import common
from common import Study
from native.evaluation.surface_error import look_up, surface_error, surface_points  # noqa: E402

TARGETS = (0.05, 0.02, 0.01)
# The error where a renderer looks the lightmaps up (native/evaluation/surface_error.py): this
# many points spread by area over the compared objects, each at least this far (metres) from
# their charts' borders, where filtering mixes in the padding.
SURFACE_POINTS = 20_000
SURFACE_INSET = 0.02
# The untimed bake before each timed one stops at this unshot fraction (warm_up()).
WARM_UP_THRESHOLD = 0.3


# ------------------------------------------------------------------------- equal error
def equal_error(scenes):
    """Per scene (a dict of scene, density, threshold, samples): Luxel's lightmaps at every
    half doubling of the shots and Cycles' bakes at 1, 4, 16, ... samples up to the
    reference's ``samples``, each against the reference; the time each reaches each target."""
    bpy, luxel = common.start_blender()
    compare, reference_module = luxel.addon.compare, luxel.addon.reference
    rows = []
    for spec in scenes:
        cold_seconds = warm_up(bpy, luxel, spec)
        common.open_blend(bpy, spec["scene"])
        context = bpy.context
        settings = context.scene.luxel
        settings.texel_density, settings.threshold = spec["density"], spec["threshold"]
        bake = compare.bake_with_snapshots(context)
        targets = reference_module.receivers(context.scene)
        started = time.perf_counter()
        first = reference_module.cycles_reference(context, samples=spec["samples"], seed=11)
        second = reference_module.cycles_reference(context, samples=spec["samples"], seed=12)
        reference_seconds = time.perf_counter() - started
        names = [obj.name for obj in targets if obj.name in first]
        reference = {name: averaged(first[name], second[name]) for name in names}
        noise, magnitude = noise_and_magnitude(names, first, second)
        # 4 x samples: Cycles' curve runs up to the reference bake's samples.
        options = compare.CompareOptions(directory="", samples=4 * spec["samples"])
        surface = SurfaceMeasure(bpy, targets, names, first, second)
        cycles = debiased(compare.cycles_curve(context, options, names, reference,
                                               measure=surface), noise, magnitude)
        luxel_curve = debiased(bake.curve(targets, names, reference, measure=surface), noise,
                               magnitude)
        row = {**spec, "texels": settings.stats.texels, "shots": settings.stats.shots,
               "cold_first_shots_seconds": cold_seconds,
               "unshot_percent": settings.stats.unshot,
               "reference_samples": 2 * spec["samples"],
               "reference_seconds": reference_seconds,
               "reference_noise_rel": math.sqrt(noise) / magnitude,
               "luxel": luxel_curve, "cycles": cycles,
               "times_to": times_to(luxel_curve, cycles),
               "surface_points": len(surface.points.page), "surface_inset": SURFACE_INSET,
               "times_to_surface": times_to(luxel_curve, cycles,
                                            key="surface_rel_rms_debiased")}
        rows.append(row)
        for entry in row["times_to"]:
            print(f"{spec['scene']} {100 * entry['target']:g} %: Luxel "
                  f"{entry['luxel_seconds']}, Cycles {entry['cycles_seconds']}", flush=True)
    return {"targets": TARGETS, "scenes": rows}


def warm_up(bpy, luxel, spec):
    """Bake the scene once to WARM_UP_THRESHOLD, untimed, so that the timed bake finds the
    process as Cycles' timed bakes do (they follow the reference's): OpenGL opened, shaders
    compiled, Cycles' kernels loaded. The charts it made are forgotten: the timed bake
    charts the scene as a first bake does. Returns the cold bake's seconds to its first
    lightmap."""
    common.open_blend(bpy, spec["scene"])
    settings = bpy.context.scene.luxel
    settings.texel_density, settings.threshold = spec["density"], WARM_UP_THRESHOLD
    bake = luxel.addon.compare.bake_with_snapshots(bpy.context)
    luxel.native.atlas.clear_cache()
    return bake.snapshots.seconds[0]


class SurfaceMeasure:
    """The error at points on the compared objects' surfaces, each looked up bilinearly in its
    object's lightmap (its Luxel UV map) as a renderer samples it, against the reference (the
    average of the bakes ``first`` and ``second``), with the reference's noise at the points
    (a quarter of their squared difference there) taken out as for the texels."""

    def __init__(self, bpy, targets, names, first, second):
        objects = {obj.name: obj for obj in targets}
        corners, texels, pages = [], [], []
        depsgraph = bpy.context.evaluated_depsgraph_get()
        for index, name in enumerate(names):
            triangle_corners, uv = world_triangles(objects[name], depsgraph)
            height, width = first[name].shape[:2]
            corners.append(triangle_corners)
            texels.append(uv * (width, height))
            pages.append(np.full(len(uv), index))
        self.names = names
        self.points = surface_points(np.concatenate(corners), np.concatenate(texels),
                                     np.concatenate(pages), count=SURFACE_POINTS,
                                     inset=SURFACE_INSET, seed=5)
        self.reference = look_up([averaged(first[n], second[n]) for n in names], self.points)
        halves = look_up([(first[n] - second[n]) / 2.0 for n in names], self.points)
        self.noise = float(np.mean(np.sum(halves ** 2, axis=1)))
        self.magnitude = math.sqrt(float(np.mean(np.sum(self.reference ** 2, axis=1))))

    def __call__(self, pages):
        error = surface_error(look_up([pages[n] for n in self.names], self.points),
                              self.reference)
        debiased_rms = math.sqrt(max(error.rms ** 2 - self.noise, 0.0))
        return {"surface_rel_rms": error.relative_rms,
                "surface_rel_rms_debiased": debiased_rms / self.magnitude}


def world_triangles(obj, depsgraph):
    """The object's evaluated triangles in world space (T, 3, 3) and their corners' lightmap
    UVs (T, 3, 2) from its Luxel UV map."""
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        mesh.calc_loop_triangles()
        count = len(mesh.loop_triangles)
        vertices = np.empty(count * 3, dtype=np.int32)
        loops = np.empty(count * 3, dtype=np.int32)
        mesh.loop_triangles.foreach_get("vertices", vertices)
        mesh.loop_triangles.foreach_get("loops", loops)
        positions = np.empty(len(mesh.vertices) * 3)
        mesh.vertices.foreach_get("co", positions)
        uv = np.empty(len(mesh.loops) * 2)
        mesh.uv_layers[obj.luxel.uv_map].data.foreach_get("uv", uv)
    finally:
        evaluated.to_mesh_clear()
    matrix = np.array(obj.matrix_world)
    world = positions.reshape(-1, 3) @ matrix[:3, :3].T + matrix[:3, 3]
    return world[vertices].reshape(-1, 3, 3), uv.reshape(-1, 2)[loops].reshape(-1, 3, 2)


def averaged(a, b):
    mean = 0.5 * (a + b)
    mean[..., 3] = a[..., 3]
    return mean


def noise_and_magnitude(names, first, second):
    """The averaged reference's noise variance per texel (RGB length squared), and its RMS."""
    squares = difference = count = 0.0
    for name in names:
        covered = first[name][..., 3] > 0.5
        a, b = first[name][covered][:, :3].astype(float), second[name][covered][:, :3]
        difference += float(((a - b) ** 2).sum())
        squares += float((((a + b) / 2) ** 2).sum())
        count += int(covered.sum())
    # var(a - b) = 2 s^2 per texel; the average's variance is s^2 / 2.
    return difference / count / 4.0, math.sqrt(squares / count)


def debiased(points, noise, magnitude):
    """The points with their debiased error; per-object errors kept on the last point only."""
    for index, point in enumerate(points):
        point["rms_debiased"] = math.sqrt(max(point["rms"] ** 2 - noise, 0.0))
        point["rel_rms_debiased"] = point["rms_debiased"] / magnitude
        if index < len(points) - 1:
            point.pop("objects", None)
    return points


def time_to(points, target, key="rel_rms_debiased"):
    """Seconds at which a curve's ``key`` first reaches ``target`` (log-log interpolation
    between the points around it), or None."""
    previous = None
    for point in points:
        error, seconds = point[key], point["seconds"]
        if error <= target:
            if previous is None or previous[0] <= 0 or error <= 0:
                return seconds
            (e0, t0), (e1, t1) = previous, (error, seconds)
            share = math.log(e0 / target) / math.log(e0 / e1) if e0 != e1 else 1.0
            return math.exp(math.log(t0) + share * (math.log(t1) - math.log(t0)))
        previous = (error, seconds)
    return None


def times_to(luxel_curve, cycles_curve, key="rel_rms_debiased"):
    rows = []
    for target in TARGETS:
        luxel_time = time_to(luxel_curve, target, key)
        cycles_time = time_to(cycles_curve, target, key)
        rows.append({"target": target, "luxel_seconds": luxel_time,
                     "cycles_seconds": cycles_time,
                     "cycles_over_luxel": (cycles_time / luxel_time
                                           if luxel_time and cycles_time else None)})
    return rows


# ---------------------------------------------------------------- Cornell box, defaults
# Block centres (x, z) in metres: a texel that is on no wall belongs to the nearer block.
BLOCK_CENTRES = {"short block": (0.185, 0.168), "tall block": (0.368, 0.351)}
CORNELL_LIGHT_CENTRE = (0.278, 0.5487, 0.2795)


def cornell_defaults(density, samples, variants):
    """The Cornell box (its light a black quad emitting from both faces 0.1 mm under the
    ceiling) baked by the solver with the default settings and with each variant ("name=value,
    ..."), against two Cycles DIFFUSE bakes of ``samples`` (64 bounces, black world) into the
    same texels, averaged. Compared: texels wholly inside a chart, over 10 cm from the light.
    Per object: Luxel's mean over Cycles' (RGB) and the irradiance power it receives."""
    from native import Settings
    from native.evaluation.texel_error import lightmap_error
    from native.samples import CORNELL_GREEN, CORNELL_RED, CORNELL_WHITE
    albedo = {"floor": CORNELL_WHITE, "ceiling": CORNELL_WHITE, "back wall": CORNELL_WHITE,
              "red wall": CORNELL_RED, "green wall": CORNELL_GREEN,
              "short block": CORNELL_WHITE, "tall block": CORNELL_WHITE}
    scene = cornell_box_two_sided_light()
    luxel = {}
    for name in ["defaults", *variants]:
        changes = {} if name == "defaults" else {
            key: setting_value(key, value)
            for key, value in (item.split("=") for item in name.split(","))}
        luxel[name] = solver_bake(scene, Settings(texel_density=density, **changes), changes)
        print(f"Luxel '{name}': {luxel[name].shots} shots, {luxel[name].seconds:.1f} s",
              flush=True)
    first = luxel["defaults"]
    texels = first.texel_samples
    bakes = [cycles_bake(scene, first.atlas, samples, seed=seed) for seed in (1, 2)]
    cycles = 0.5 * (bakes[0].pixels + bakes[1].pixels)
    compared = (texels["occupied"] & (texels["coverage"] > 0.999)
                & (np.linalg.norm(texels["position"] - np.array(CORNELL_LIGHT_CENTRE),
                                  axis=2) > 0.1))
    objects = {name: mask & compared for name, mask in cornell_objects(texels).items()}
    emitted = float(np.mean(first.ledger.emitted))
    difference = (bakes[0].pixels - bakes[1].pixels)[compared][:, :3].astype(np.float64)
    noise_square = float((difference ** 2).sum(axis=1).mean()) / 4.0
    runs = {}
    for name, run in luxel.items():
        error = lightmap_error([np.dstack([run.image[..., :3], compared])],
                               [np.dstack([cycles[..., :3], compared])])
        per_object = {}
        for object_name, mask in objects.items():
            received = [float(np.mean(received_power(pixels, mask, texels["area"],
                                                     albedo[object_name])))
                        for pixels in (run.image, cycles)]
            per_object[object_name] = {
                "texels": int(mask.sum()),
                "mean_ratio_rgb": (run.image[mask][:, :3].sum(axis=0)
                                   / cycles[mask][:, :3].sum(axis=0)),
                "received_w": received[0], "cycles_received_w": received[1]}
        runs[name] = {
            "settings": run.settings, "shots": run.shots, "seconds": run.seconds,
            "unshot_fraction": run.unshot_fraction, "relative_rms": error.relative_rms,
            "relative_rms_less_noise": math.sqrt(max(error.rms ** 2 - noise_square, 0.0))
            / error.reference_rms,
            "reference_noise_relative_rms": math.sqrt(noise_square) / error.reference_rms,
            "ledger_share": {key: float(np.mean(getattr(run.ledger, key)) / emitted)
                             for key in ("absorbed", "escaped", "unshot")},
            "objects": per_object}
        ratios = [value for entry in per_object.values() for value in entry["mean_ratio_rgb"]]
        print(f"{name}: relative RMS {runs[name]['relative_rms_less_noise']:.2%} less "
              f"Cycles' noise, objects' means {min(ratios):.4f}-{max(ratios):.4f}", flush=True)
    return {"density": density, "samples": samples, "texels": first.texels,
            "compared": int(compared.sum()),
            "cycles_seconds": [bake.seconds for bake in bakes], "emitted_w": emitted,
            "runs": runs}


def setting_value(name, text):
    """A variant's value as its setting's kind: "0" and "false" are False for a switch."""
    from native import Settings
    kind = type(getattr(Settings(), name))
    if kind is bool:
        return text.lower() not in ("0", "false", "no", "off")
    return kind(text)


def cornell_box_two_sided_light():
    """The Cornell box with a black light that emits from both faces, as a Blender quad with
    an emission shader does."""
    from native.samples import cornell_box
    scene = cornell_box()
    light = scene.object_index == scene.object_names.index("light")
    scene.albedo[light] = 0.0
    scene.emission_two_sided[light] = True
    scene.__post_init__()
    return scene


@dataclasses.dataclass
class LuxelBake:
    """A solver bake of the Cornell box: its first page, texel samples and ledger."""
    settings: dict
    image: np.ndarray
    texel_samples: dict
    atlas: object
    texels: int
    shots: int
    unshot_fraction: float
    ledger: object
    seconds: float


def solver_bake(scene, settings, changes):
    from native import Solver
    start = time.perf_counter()
    with Solver(scene, settings) as solver:
        solver.run()
        image, texel_samples = solver.result()[0], solver.texel_samples()[0]
        return LuxelBake(changes, image, texel_samples, solver.atlas, solver.texel_count,
                         solver.shots, solver.progress.unshot_fraction, solver.ledger(),
                         time.perf_counter() - start)


def cornell_objects(samples):
    """Per object a boolean map of its texels, told apart by position and normal."""
    position, normal = samples["position"], samples["normal"]
    objects = {
        "floor": (position[..., 1] < 1e-4) & (normal[..., 1] > 0.99),
        "ceiling": (position[..., 1] > 0.5487) & (normal[..., 1] < -0.99),
        "back wall": (position[..., 2] > 0.5591) & (normal[..., 2] < -0.99),
        "red wall": (position[..., 0] > 0.5495) & (normal[..., 0] < -0.99),
        "green wall": (position[..., 0] < 1e-4) & (normal[..., 0] > 0.99),
    }
    blocks = ~np.logical_or.reduce(list(objects.values()))
    distance = {name: np.hypot(position[..., 0] - x, position[..., 2] - z)
                for name, (x, z) in BLOCK_CENTRES.items()}
    objects["short block"] = blocks & (distance["short block"] < distance["tall block"])
    objects["tall block"] = blocks & ~objects["short block"]
    return objects


def received_power(image, mask, area, albedo):
    """Irradiance power (W, RGB) on the masked texels: pi L / rho times their area."""
    return (math.pi * image[mask][:, :3] / np.asarray(albedo) * area[mask][:, None]).sum(axis=0)


@dataclasses.dataclass
class CyclesBake:
    pixels: np.ndarray
    seconds: float


def cycles_bake(scene, atlas, samples, *, seed, bounces=64):
    """Cycles' DIFFUSE bake (direct, indirect, colour) of the Cornell box ``scene`` into the
    atlas's lightmap UVs, built in an empty Blender scene: each object a mesh with a Diffuse
    BSDF, the light a quad with an Emission shader on both faces (not baked), a black world."""
    import bpy      # the bare module: this scene needs no Luxel in Blender
    from native.samples import CORNELL_LIGHT
    bpy.ops.wm.read_factory_settings(use_empty=True)
    blender = bpy.context.scene
    blender.render.engine = "CYCLES"
    cycles = blender.cycles
    cycles.device, cycles.samples, cycles.seed = "CPU", samples, seed
    cycles.use_adaptive_sampling = cycles.use_denoising = False
    cycles.max_bounces = cycles.diffuse_bounces = bounces
    cycles.sample_clamp_direct = cycles.sample_clamp_indirect = 0.0
    world = bpy.data.worlds.new("black")    # a new world shines grey through its node tree
    world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    background.inputs["Strength"].default_value = 0.0
    blender.world = world
    image = bpy.data.images.new("bake", atlas.width, atlas.height, float_buffer=True, alpha=True)
    light_index = scene.object_names.index("light")
    uv = atlas.uv()
    row_of = {int(t): row for row, t in enumerate(atlas.triangles)}

    def mesh_of(index):
        triangles = np.nonzero(scene.object_index == index)[0]
        used, local = np.unique(scene.triangles[triangles], return_inverse=True)
        mesh = bpy.data.meshes.new(scene.object_names[index])
        mesh.from_pydata(scene.vertices[used].tolist(), [], local.reshape(-1, 3).tolist())
        material = bpy.data.materials.new(scene.object_names[index])
        material.use_nodes = True
        material.node_tree.nodes.clear()
        mesh.materials.append(material)
        return mesh, triangles, material.node_tree
    for index in range(len(scene.object_names)):
        if index == light_index:
            continue
        mesh, triangles, tree = mesh_of(index)
        layer = mesh.uv_layers.new(name="Lightmap")
        for polygon, triangle in zip(mesh.polygons, triangles):
            for corner, loop in enumerate(polygon.loop_indices):
                layer.data[loop].uv = uv[row_of[int(triangle)], corner]
        diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
        diffuse.inputs["Color"].default_value = (*scene.albedo[triangles[0]], 1.0)
        tree.links.new(diffuse.outputs["BSDF"],
                       tree.nodes.new("ShaderNodeOutputMaterial").inputs["Surface"])
        target = tree.nodes.new("ShaderNodeTexImage")
        target.image = image
        tree.nodes.active = target
        blender.collection.objects.link(bpy.data.objects.new(mesh.name, mesh))
    mesh, _, tree = mesh_of(light_index)
    emission = tree.nodes.new("ShaderNodeEmission")
    strongest = max(CORNELL_LIGHT)
    emission.inputs["Color"].default_value = (*(c / strongest for c in CORNELL_LIGHT), 1.0)
    emission.inputs["Strength"].default_value = strongest
    tree.links.new(emission.outputs["Emission"],
                   tree.nodes.new("ShaderNodeOutputMaterial").inputs["Surface"])
    blender.collection.objects.link(bpy.data.objects.new("light", mesh))
    for obj in blender.objects:
        obj.select_set(obj.name != "light")
    bpy.context.view_layer.objects.active = next(o for o in blender.objects if o.name != "light")
    start = time.perf_counter()
    bpy.ops.object.bake(type="DIFFUSE", pass_filter={"DIRECT", "INDIRECT", "COLOR"}, margin=0,
                        use_clear=True)
    seconds = time.perf_counter() - start
    pixels = np.array(image.pixels[:], dtype=np.float32).reshape(atlas.height, atlas.width, 4)
    return CyclesBake(pixels, seconds)


# ---------------------------------------------------------------- the realistic interior
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def interior(blends, threshold, samples, supersample, materials):
    """Each blend (a dict of blend and density) at ``threshold``, with the file's own
    materials ("file") and with every Principled BSDF at Blender's default specular layer
    ("default": Specular IOR Level 0.5, Roughness 0.5), baked through the extension; every
    shown copy's mean against Cycles' bake into the same texels (``samples``, 32 bounces, the
    mean of ``supersample`` squared sub-texels a texel: reference.cycles_reference), and the
    share of the rendered surface that gets a lightmap."""
    bpy, luxel = common.start_blender()
    addon = luxel.addon
    runs = []
    for spec in blends:
        for kind in materials:
            blend = spec["blend"]
            common.open_blend(bpy, blend)
            scene = bpy.context.scene
            scene.luxel.texel_density, scene.luxel.threshold = spec["density"], threshold
            if kind == "default":
                default_specular(bpy)
            export = addon.export.export_scene(bpy.context)
            solver_scene = export.scene
            lights = {obj.name for obj in scene.objects if obj.type == 'LIGHT'}
            surface = np.array([name not in lights for name in solver_scene.object_names])
            area = solver_scene.triangle_area
            rendered = area[surface[solver_scene.object_index]].sum()
            shown = sum(area[r.first_triangle:r.first_triangle + len(r.loops)].sum()
                        for r in export.receivers)
            started = time.perf_counter()
            assert bpy.ops.luxel.bake() == {'FINISHED'}
            bake_seconds = time.perf_counter() - started
            stats = scene.luxel.stats
            started = time.perf_counter()
            cycles = addon.reference.cycles_reference(bpy.context, samples, 32, copies=True,
                                                      supersample=supersample)
            cycles_seconds = time.perf_counter() - started
            objects = []
            for name, mean in sorted(addon.reference.object_means(cycles).items()):
                # A copy none of whose texel centres Cycles baked has no mean to compare.
                ratio = (float(mean.luxel @ LUMINANCE / max(mean.cycles @ LUMINANCE, 1e-30))
                         if mean.texels else None)
                objects.append({"object": name, "texels": mean.texels, "ratio": ratio,
                                "luxel": mean.luxel, "cycles": mean.cycles})
            deviations = [abs(entry["ratio"] - 1.0) for entry in objects
                          if entry["ratio"] is not None]
            run = {"blend": blend, "density": spec["density"], "materials": kind,
                   "triangles": len(solver_scene.triangles), "copies": len(deviations),
                   "area_shown": float(shown / rendered),
                   "bake_seconds": bake_seconds, "texels": stats.texels, "shots": stats.shots,
                   "unshot_percent": stats.unshot, "cycles_seconds": cycles_seconds,
                   "within_3_percent": sum(d <= 0.03 for d in deviations),
                   "within_5_percent": sum(d <= 0.05 for d in deviations),
                   "largest_deviation": max(deviations), "objects": objects,
                   "warnings": list(export.warnings)}
            runs.append(run)
            print(f"{blend}, {kind} materials: {run['within_3_percent']} of {run['copies']} "
                  f"copies within 3 %, largest {run['largest_deviation']:.3f}; bake "
                  f"{bake_seconds:.1f} s, Cycles {cycles_seconds:.1f} s", flush=True)
    return {"threshold": threshold, "cycles_samples": samples,
            "cycles_supersample": supersample, "runs": runs}


def default_specular(bpy):
    for material in bpy.data.materials:
        for node in material.node_tree.nodes if material.node_tree else ():
            if node.bl_idname == 'ShaderNodeBsdfPrincipled':
                node.inputs["Specular IOR Level"].default_value = 0.5
                node.inputs["Roughness"].default_value = 0.5


# ----------------------------------------------------------------------------- materials
FURNACE_TEXELS = 64
FURNACE_RINGS, FURNACE_SEGMENTS = 48, 96
FURNACE_POLE = 0.2            # radius of the pole's texels in the projection
FURNACE_COSINES = (0.95, 0.65, 0.35, 0.15)
FURNACE_MATERIALS = {
    "matte (specular 0, roughness 1)": {"Roughness": 1.0, "Specular IOR Level": 0.0},
    "default, roughness 1": {"Roughness": 1.0},
    "default (roughness 0.5)": {},
    "default, roughness 0.2": {"Roughness": 0.2},
    "default, roughness 0.35": {"Roughness": 0.35},
    "default, roughness 0.75": {"Roughness": 0.75},
    "default, base 0.4": {"Base Color": (0.4, 0.4, 0.4, 1.0)},
    "default, base 0.1": {"Base Color": (0.1, 0.1, 0.1, 1.0)},
    "coat 1": {"Coat Weight": 1.0},
    "sheen 1": {"Sheen Weight": 1.0},
    "metal, roughness 0.2": {"Metallic": 1.0, "Roughness": 0.2},
    "metal, roughness 0.5": {"Metallic": 1.0},
    "metal, roughness 1": {"Metallic": 1.0, "Roughness": 1.0},
}


def materials(scenes, repeats):
    """What evaluating the materials with Cycles costs (addon/materials.py): per sample .blend
    at its own settings, the median seconds of ``repeats`` calls of evaluate_materials (the
    export and the atlas outside them: the atlas is charted once, then cached)."""
    bpy, luxel = common.start_blender()
    addon = luxel.addon
    rows = []
    for name in scenes:
        common.open_blend(bpy, name)
        settings = bpy.context.scene.luxel.solver_settings()
        export = addon.export.export_scene(bpy.context)
        atlas = luxel.native.lightmap_atlas(export.scene, settings)    # charted and cached
        seconds = []
        for _ in range(repeats):
            export = addon.export.export_scene(bpy.context)
            started = time.perf_counter()
            addon.materials.evaluate_materials(bpy.context.evaluated_depsgraph_get(), export,
                                               settings)
            seconds.append(time.perf_counter() - started)
        rows.append({"scene": name, "triangles": len(export.scene.triangles),
                     "density": settings.texel_density,
                     "page_texels": atlas.width * atlas.height * atlas.page_count,
                     "mesh_copies": len(export.surfaces), "seconds": seconds,
                     "median_seconds": statistics.median(seconds)})
        print(f"{name}: materials {rows[-1]['median_seconds']:.2f} s", flush=True)
    return {"scenes": rows}


def glossy_furnace(samples):
    """What a Principled BSDF reflects as Cycles evaluates it against what Luxel reflects (its
    DIFFUSE plus GLOSSY colour at normal incidence), in a white furnace. A hemisphere of each
    material under a white sky of radiance 1 is baked (COMBINED, reflected light only, one
    bounce: a convex hemisphere sees only the sky) from an orthographic camera on its axis,
    so that a texel holds the directional albedo seen at its angle; its UVs are its
    orthographic projection onto its base, so every texel weighs the same share of the
    cosine-weighted hemisphere. Green channel. Per material: the diffuse and glossy parts at
    normal incidence (what Luxel reflects), their cosine-weighted means (the white-sky
    albedo), and the glossy part at a few angles."""
    bpy, luxel = common.start_blender()
    scene, hemisphere, image = furnace_scene(bpy, luxel, samples)
    side = (np.arange(FURNACE_TEXELS) + 0.5) / FURNACE_TEXELS * 2.0 - 1.0
    radius = np.hypot(side[None, :], side[:, None])
    cosine = np.sqrt(np.clip(1.0 - radius ** 2, 0.0, 1.0))
    inside = radius < 1.0
    pole = inside & (radius < FURNACE_POLE)
    rows = []
    for name, inputs in FURNACE_MATERIALS.items():
        material = bpy.data.materials.new(name)
        if material.node_tree is None:
            material.use_nodes = True
        principled = material.node_tree.nodes["Principled BSDF"]
        for socket, value in inputs.items():
            principled.inputs[socket].default_value = value
        target = material.node_tree.nodes.new('ShaderNodeTexImage')
        target.image = image
        material.node_tree.nodes.active = target
        hemisphere.data.materials.clear()
        hemisphere.data.materials.append(material)
        diffuse, glossy = (furnace_bake(bpy, scene, hemisphere, image, part)
                           for part in ('DIFFUSE', 'GLOSSY'))
        row = {"material": name,
               "diffuse_normal": float(diffuse[pole].mean()),
               "glossy_normal": float(glossy[pole].mean()),
               "diffuse_white_sky": float(diffuse[inside].mean()),
               "glossy_white_sky": float(glossy[inside].mean()),
               "glossy_at": {str(c): float(glossy[inside & (np.abs(cosine - c) < 0.05)].mean())
                             for c in FURNACE_COSINES}}
        row["luxel"] = row["diffuse_normal"] + row["glossy_normal"]
        row["white_sky"] = row["diffuse_white_sky"] + row["glossy_white_sky"]
        rows.append(row)
        print(f"{name:>32}: normal {row['luxel']:.4f}, white sky {row['white_sky']:.4f}",
              flush=True)
    return {"samples": samples, "texels": FURNACE_TEXELS, "rows": rows}


def furnace_scene(bpy, luxel, samples):
    scene = bpy.data.scenes.new("Furnace")
    # The reference's settings: no clamping, no Filter Glossy; one bounce.
    luxel.addon.reference.configure_cycles(scene, samples, bounces=1, seed=0)
    scene.render.bake.view_from = 'ACTIVE_CAMERA'
    world = scene.world = bpy.data.worlds.new("Sky")
    if world.node_tree is None:         # Blender before 5.0 makes it on use_nodes
        world.use_nodes = True
    sky = next(n for n in world.node_tree.nodes if n.bl_idname == 'ShaderNodeBackground')
    sky.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    sky.inputs["Strength"].default_value = 1.0
    polar = np.arange(1, FURNACE_RINGS + 1) / FURNACE_RINGS * np.pi / 2
    azimuth = np.arange(FURNACE_SEGMENTS) / FURNACE_SEGMENTS * 2 * np.pi
    ring = np.stack([np.outer(np.sin(polar), np.cos(azimuth)),
                     np.outer(np.sin(polar), np.sin(azimuth)),
                     np.repeat(np.cos(polar)[:, None], FURNACE_SEGMENTS, axis=1)], axis=2)
    vertices = np.concatenate([[(0.0, 0.0, 1.0)], ring.reshape(-1, 3)])
    following = (np.arange(FURNACE_SEGMENTS) + 1) % FURNACE_SEGMENTS
    faces = [(0, 1 + j, 1 + k) for j, k in enumerate(following)]
    for i in range(FURNACE_RINGS - 1):
        upper, lower = 1 + i * FURNACE_SEGMENTS, 1 + (i + 1) * FURNACE_SEGMENTS
        faces += [(upper + j, lower + j, lower + k, upper + k) for j, k in enumerate(following)]
    mesh = bpy.data.meshes.new("Hemisphere")
    mesh.from_pydata(vertices.tolist(), [], faces)
    mesh.polygons.foreach_set("use_smooth", np.ones(len(faces), dtype=bool))
    corners = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", corners)
    layer = mesh.uv_layers.new(name="Projection")
    layer.uv.foreach_set("vector", ((vertices[corners, :2] + 1) / 2).astype(np.float32).ravel())
    hemisphere = bpy.data.objects.new("Hemisphere", mesh)
    scene.collection.objects.link(hemisphere)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.type = 'ORTHO'
    camera.location = (0.0, 0.0, 2.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    image = bpy.data.images.new("Furnace", FURNACE_TEXELS, FURNACE_TEXELS, alpha=True,
                                float_buffer=True)
    image.colorspace_settings.name = 'Linear Rec.709'
    return scene, hemisphere, image


def furnace_bake(bpy, scene, hemisphere, image, part):
    image.pixels.foreach_set(np.zeros(FURNACE_TEXELS * FURNACE_TEXELS * 4, dtype=np.float32))
    with bpy.context.temp_override(scene=scene, view_layer=scene.view_layers[0],
                                   selected_objects=[hemisphere],
                                   selected_editable_objects=[hemisphere],
                                   active_object=hemisphere, object=hemisphere):
        bpy.ops.object.bake(type='COMBINED', pass_filter={'DIRECT', 'INDIRECT', part},
                            uv_layer="Projection", margin=0, use_clear=False,
                            target='IMAGE_TEXTURES')
    pixels = np.empty(FURNACE_TEXELS * FURNACE_TEXELS * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    return pixels.reshape(FURNACE_TEXELS, FURNACE_TEXELS, 4)[..., 1]


def scene_spec(scene, density, threshold, samples):
    return {"scene": scene, "density": density, "threshold": threshold, "samples": samples}


STUDIES = (
    Study("equal-error", equal_error, {
        "quick": dict(scenes=[scene_spec("cornell_box", 20.0, 0.05, 16)]),
        "cpu": dict(scenes=[scene_spec("cornell_box", 60.0, 0.002, 1024),
                            scene_spec("cornell_box", 160.0, 0.002, 1024),
                            scene_spec("cornell_primitives", 60.0, 0.002, 1024),
                            scene_spec("cornell_primitives", 160.0, 0.002, 1024),
                            scene_spec("living", 8.0, 0.01, 256),
                            scene_spec("office", 4.0, 0.05, 256),
                            scene_spec("temple", 2.0, 0.02, 128)]),
        "gpu": dict(scenes=[scene_spec("cornell_box", 60.0, 0.002, 1024),
                            scene_spec("living", 8.0, 0.002, 512),
                            scene_spec("office", 4.0, 0.002, 1024),
                            scene_spec("temple", 2.0, 0.002, 512)])}, blender=True),
    Study("cornell-defaults", cornell_defaults, {
        "quick": dict(density=40.0, samples=16, variants=[]),
        "cpu": dict(density=160.0, samples=128, variants=[]),
        "gpu": dict(density=160.0, samples=512,
                    variants=["neighbour_visibility=0", "hemicube_resolution=128", "ambient=0",
                              "projection=HEMISPHERE", "threshold=0.003"])}, blender=True),
    Study("interior", interior, {
        "quick": dict(blends=[{"blend": "interior", "density": 3.0}], threshold=0.2,
                      samples=16, supersample=1, materials=["file"]),
        "cpu": dict(blends=[{"blend": "interior", "density": 10.0}], threshold=0.02,
                    samples=128, supersample=2, materials=["file", "default"]),
        "gpu": dict(blends=[{"blend": "interior", "density": 10.0},
                            {"blend": "office", "density": 4.0}], threshold=0.002,
                    samples=2048, supersample=4, materials=["file", "default"])},
          blender=True),
    Study("materials", materials, {
        "quick": dict(scenes=["cornell_box"], repeats=1),
        "cpu": dict(scenes=["cornell_box", "interior", "office"], repeats=3),
        "gpu": dict(scenes=["cornell_box", "interior", "office"], repeats=3)}, blender=True),
    Study("glossy-furnace", glossy_furnace, {
        "quick": dict(samples=4), "cpu": dict(samples=64), "gpu": dict(samples=256)},
          blender=True),
)

if __name__ == "__main__":
    common.main(__doc__.split("\n\n")[0], STUDIES)
