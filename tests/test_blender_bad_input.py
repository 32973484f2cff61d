"""Bad input through Blender: a clear error or warning naming the object, material or light and
the fix, and the .blend (images, UV maps, materials, meshes, Luxel's results) and the lightmap
files exactly as they were whenever a bake is refused, cancelled or fails."""
import errno
import hashlib
import itertools
import math
import os
import re
import subprocess
import sys
from dataclasses import replace
from types import SimpleNamespace

import moderngl
import numpy as np
import OpenEXR
import pytest

import blender_session
from test_blender_addon import cube, material, mesh_object, light, room_scene, texels_of

bpy = blender_session.blender()
luxel = blender_session.addon()
addon, native = luxel.addon, luxel.native
LUXEL_OT_bake = addon.operators.LUXEL_OT_bake


# --------------------------------------------------------------------------------- helpers
def _digest(collection, attribute, width):
    values = np.empty(len(collection) * width, dtype=np.float32)
    collection.foreach_get(attribute, values)
    return hashlib.sha1(values.tobytes()).hexdigest()


def _pixels(image):
    values = np.empty(len(image.pixels), dtype=np.float32)
    image.pixels.foreach_get(values)
    return hashlib.sha1(values.tobytes()).hexdigest()


def blend_state(scene, folder=None):
    """Everything a refused, cancelled or failed bake must leave as it was: each image (pixels,
    file, packing), each mesh (vertices, faces, UV maps and their values, materials), each
    object's Luxel record, every material's nodes, the scene's Luxel results, and the files in
    ``folder``, hidden ones included."""
    images = {image.name: (tuple(image.size), image.source, image.filepath,
                           image.packed_file is not None, sorted(image.keys()), _pixels(image))
              for image in bpy.data.images}
    meshes = {obj.name: (len(obj.data.polygons), _digest(obj.data.vertices, "co", 3),
                         [(layer.name, layer.active, layer.active_render,
                           _digest(layer.uv, "vector", 2)) for layer in obj.data.uv_layers],
                         [slot.material.name if slot.material else None
                          for slot in obj.material_slots])
              for obj in scene.objects if obj.type == 'MESH'}
    records = {obj.name: (obj.luxel.image.name if obj.luxel.image else None, obj.luxel.uv_map)
               for obj in scene.objects}
    trees = {mat.name: ([(node.name, node.bl_idname, getattr(node, "is_active_output", None),
                          getattr(node, "image", None) and node.image.name)
                         for node in mat.node_tree.nodes],
                        sorted((link.from_node.name, link.to_node.name)
                               for link in mat.node_tree.links),
                        sorted(mat.keys()))
             for mat in bpy.data.materials}
    stats = scene.luxel.stats
    emission = {name: list(value)
                for name, value in scene.luxel.get("material_emission", {}).items()}
    results = ((stats.valid, stats.texels, stats.shots, stats.pages, stats.seconds), emission,
               scene.luxel.show_baked)
    files = None
    if folder is not None and os.path.isdir(folder):
        files = {name: hashlib.sha1((folder / name).read_bytes()).hexdigest()
                 for name in sorted(os.listdir(folder))}
    return images, meshes, records, trees, results, files


def fast(scene):
    """Settings that bake the room in about a second."""
    scene.luxel.texel_density = 5.0
    scene.luxel.threshold = 0.05
    return scene


def bake_error(match):
    """bpy.ops.luxel.bake() refusing: in background mode an ERROR report raises."""
    with pytest.raises(RuntimeError, match=match) as error:
        bpy.ops.luxel.bake()
    return str(error.value)


def run_cli(argv):
    return addon.cli.execute(argv)


def one_line(capsys):
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


class FailingSteps:
    """Solver.step that raises ``error`` at call ``after`` + 1, keeping the solvers it ran."""

    def __init__(self, monkeypatch, error, after=3):
        self.error, self.after, self.calls, self.solvers = error, after, 0, []
        original = native.Solver.step

        def step(solver):
            self.calls += 1
            if solver not in self.solvers:
                self.solvers.append(solver)
            if self.calls > self.after:
                raise self.error
            return original(solver)

        monkeypatch.setattr(native.Solver, "step", step)

    def all_released(self):
        return bool(self.solvers) and all(s.ctx is None and s.gl_object_count == 0
                                          for s in self.solvers)


class OperatorDriver:
    """LUXEL_OT_bake's own methods on a stand-in for the operator, which records its reports
    and returns what execute() and modal() return (bpy.ops only raises on an error). With the
    bpy module (background mode) invoke() runs execute(), and no timer or key events come, so
    Esc cannot be pressed: start_modal() does what invoke() does for a window, and event()
    hands modal() a fake event."""
    execute, modal, _start, _finish, _fail, _end_modal, _report_warnings = (
        LUXEL_OT_bake.execute, LUXEL_OT_bake.modal, LUXEL_OT_bake._start,
        LUXEL_OT_bake._finish, LUXEL_OT_bake._fail, LUXEL_OT_bake._end_modal,
        LUXEL_OT_bake._report_warnings)

    def __init__(self):
        self.reports = []
        self.progress = []      # the progress bar's values, 0..1000
        self.status = []        # the status bar's texts (None: cleared)
        self._timer = object()
        wm = SimpleNamespace(event_timer_remove=lambda timer: None, progress_end=lambda: None,
                             progress_update=self.progress.append)
        self.context = SimpleNamespace(window_manager=wm, workspace=SimpleNamespace(
            status_text_set=self.status.append))

    def report(self, kind, message):
        self.reports.append((next(iter(kind)), message))

    def start_modal(self):
        self._job = self._start(bpy.context)
        LUXEL_OT_bake._modal_running = True

    def event(self, kind):
        return self.modal(self.context, SimpleNamespace(type=kind))


def released(job):
    """The job's GPU freed (a job cancelled before the solver started has none)."""
    return job.solver is None or (job.solver.ctx is None and job.solver.gl_object_count == 0)


@pytest.fixture(autouse=True)
def no_modal_bake_left_running():
    yield
    LUXEL_OT_bake._modal_running = False


# ---------------------------------------------------------------------------- geometry
def broken_panel(scene, name="broken"):
    """A 1 m panel 1 m above the room's floor (two good triangles) with a zero-area triangle
    (three points on a line) and a triangle whose vertex is NaN."""
    vertices = [(-0.5, -0.5, 1), (0.5, -0.5, 1), (0.5, 0.5, 1), (-0.5, 0.5, 1),
                (1, 1, 1), (1.2, 1.2, 1), (1.4, 1.4, 1),
                (-1, 1, 1), (-1.2, 1, 1), (-1, 1.2, 1)]
    obj = mesh_object(scene, name, vertices, [(0, 1, 2, 3), (4, 5, 6), (7, 8, 9)],
                      material(name, (0.5, 0.5, 0.5)))
    obj.data.vertices[9].co = (math.nan, 1.2, 1.0)
    return obj


def test_zero_area_and_nan_triangles_are_skipped_with_one_warning_naming_the_object():
    scene = fast(room_scene())
    panel = broken_panel(scene)
    result = addon.export.export_scene(bpy.context)
    named = [warning for warning in result.warnings if "'broken'" in warning]
    assert named == ["'broken': 2 of its 4 triangles were skipped (1 with zero area, 1 with a "
                     "vertex that is not a finite number); fix the mesh in Edit Mode: Mesh > "
                     "Clean Up > Merge by Distance and Delete Loose, and delete vertices at "
                     "invalid positions"]
    index = result.scene.object_names.index("broken")
    assert (result.scene.object_index == index).sum() == 2

    assert bpy.ops.luxel.bake() == {'FINISHED'}
    uv = np.empty(len(panel.data.loops) * 2)
    panel.data.uv_layers["LuxelLightmap"].uv.foreach_get("vector", uv)
    quad_uv = uv.reshape(-1, 2)[list(panel.data.polygons[0].loop_indices)]
    assert np.ptp(quad_uv, axis=0).min() > 0.0, "the good quad has its own lightmap chart"
    assert np.isfinite(texels_of(panel)).all() and texels_of(panel)[0].min() > 0.0


def test_objects_with_nothing_to_bake_are_skipped_with_a_warning_naming_them():
    scene = fast(room_scene())
    mesh_object(scene, "sliver", [(0, 0, 1), (1, 0, 1), (2, 0, 1)], [(0, 1, 2)], None)
    wire = bpy.data.meshes.new("wire")
    wire.from_pydata([(0, 0, 1), (1, 0, 1)], [(0, 1)], [])
    scene.collection.objects.link(bpy.data.objects.new("wire", wire))
    result = addon.export.export_scene(bpy.context)
    assert "sliver" not in result.scene.object_names and "wire" not in result.scene.object_names
    assert any(w.startswith("'sliver' was skipped: none of its triangles can be baked (1 with "
                            "zero area)") and "Merge by Distance" in w for w in result.warnings)
    assert any(w.startswith("'wire' is a mesh without faces") for w in result.warnings)
    assert bpy.ops.luxel.bake() == {'FINISHED'}
    assert "LuxelLightmap" not in scene.objects["sliver"].data.uv_layers


def test_a_scene_of_unusable_meshes_is_refused_as_having_no_mesh():
    scene = fast(blender_session.empty_file())
    broken = mesh_object(scene, "broken", [(0, 0, 0), (1, 0, 0), (1, 1, 0)], [(0, 1, 2)], None)
    broken.data.vertices[0].co = (math.inf, 0.0, 0.0)
    light(scene, "lamp", 'POINT', (0, 0, 2))
    before = blend_state(scene)
    assert "no visible mesh" in bake_error("no visible mesh")
    assert blend_state(scene) == before


# --------------------------------------------------------------------------- materials
def test_faces_without_a_material_are_default_grey_with_a_warning_naming_the_object():
    scene = fast(room_scene())
    cube(scene, "bare", 0.5, (-1, 1, 0.5))
    two_slots = cube(scene, "half bare", 0.5, (1, -1, 0.5), material("red", (0.6, 0.1, 0.1)))
    two_slots.data.materials.append(None)
    two_slots.data.polygons[0].material_index = 1
    result = addon.bake.BakeJob(bpy.context)
    result.set_up()
    result.release()
    scene_out = result.export.scene
    albedo = albedo_at_centres(scene_out)
    for name, grey_faces in (("bare", 6), ("half bare", 1)):
        mine = albedo[scene_out.object_index == scene_out.object_names.index(name)]
        assert (np.abs(mine - 0.8) < 1e-3).all(axis=1).sum() == 2 * grey_faces, name
        assert any(w.startswith(f"'{name}' has faces without a material") and
                   "assign a material" in w for w in result.warnings), name
    assert not any("'room'" in warning for warning in result.warnings)
    assert bpy.ops.luxel.bake() == {'FINISHED'}


def missing_image(name):
    """The image an importer leaves where the file is not found: one with no pixels."""
    image = bpy.data.images.get(name)
    if image is None:
        image = bpy.data.images.new(name, 8, 8)
        image.source = 'FILE'
        image.filepath = f"//textures/{name}"
        image.reload()
    return image


def test_an_imported_level_missing_its_images_gets_one_short_warning_naming_them():
    """A level imported from OBJ with its texture folder left behind: a material per surface,
    each reading an image with no pixels. One warning names the images and some of the
    materials; the one that a white level's albedo is lowered names the object and some of
    its materials: each short enough for Blender's report (it cuts at 1,024 characters) to
    keep its fix."""
    scene = fast(room_scene())
    level = cube(scene, "level", 0.6, (0.8, -0.8, 0.5))
    materials = []
    for index in range(6):
        imported = bpy.data.materials.new(f"slot{index}")
        if imported.node_tree is None:     # Blender before 5.0 makes it on use_nodes
            imported.use_nodes = True
        texture = imported.node_tree.nodes.new("ShaderNodeTexImage")
        texture.image = missing_image(f"wall_{index % 2}.jpg")
        shader = imported.node_tree.nodes["Principled BSDF"]
        imported.node_tree.links.new(texture.outputs["Color"], shader.inputs["Base Color"])
        level.data.materials.append(imported)
        materials.append(imported.name)
    white = cube(scene, "white level", 0.6, (-0.8, 0.8, 0.5))
    for index in range(6):
        white.data.materials.append(material(f"white{index}", (1.0, 1.0, 1.0)))
    for obj in (level, white):
        for face, polygon in enumerate(obj.data.polygons):
            polygon.material_index = face
    job = addon.bake.BakeJob(bpy.context)
    job.set_up()
    job.release()
    missing = [w for w in job.warnings if "no pixels" in w]
    assert len(missing) == 1, job.warnings
    assert ("'wall_0.jpg'" in missing[0] and "'wall_1.jpg'" in missing[0]
            and "'slot0', 'slot1', 'slot2' and 3 more" in missing[0]
            and "Find Missing Files" in missing[0])
    lowered = [w for w in job.warnings if w.startswith("'white level'")]
    assert lowered == ["'white level' (materials 'white0', 'white1', 'white2' and 3 more) "
                       "reflects more than 0.999 of the light in places (a colour of 1 or "
                       "more): lowered to 0.999, since a surface cannot reflect all light"]
    assert all(len(warning) < 400 for warning in job.warnings)
    assert not any("slot5" in warning or "white5" in warning for warning in job.warnings)


def albedo_at_centres(scene):
    """Each triangle's albedo as the solver reads it at the centre of its texture corners
    (Cycles' evaluation per texel, materials.evaluate_materials)."""
    albedo = scene.albedo.copy()
    for index in np.nonzero(scene.albedo_texture_index >= 0)[0]:
        image = scene.albedo_textures[scene.albedo_texture_index[index]]
        u, v = scene.albedo_uv[index].mean(axis=0)
        albedo[index] *= image[int(v * image.shape[0]), int(u * image.shape[1])]
    return albedo


def test_negative_emission_light_and_texture_are_clamped_with_warnings_naming_them():
    scene = fast(room_scene())
    cube(scene, "glowing", 0.4, (1, 1, 0.5),
         material("glow", (0.5, 0.5, 0.5), emission=(1.0, 1.0, 1.0), strength=-5.0))
    shine = bpy.data.materials.new("shine")
    emission = shine.node_tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = -2.0
    shine.node_tree.links.new(emission.outputs[0],
                              shine.node_tree.nodes["Material Output"].inputs["Surface"])
    cube(scene, "shining", 0.4, (1, -1, 0.5), shine)
    image = bpy.data.images.new("negative", 2, 2, float_buffer=True)
    image.pixels.foreach_set([-0.5, 0.2, 0.3, 1.0] * 4)
    textured = material("textured", (0.5, 0.5, 0.5))
    texture = textured.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    textured.node_tree.links.new(texture.outputs["Color"],
                                 textured.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    cube(scene, "painted", 0.4, (-1, 0, 0.5), textured).data.uv_layers.new(name="UVMap")
    light(scene, "sink", 'POINT', (0, 0, 3), energy=-100.0)

    job = addon.bake.BakeJob(bpy.context)
    job.set_up()
    job.release()
    # Cycles itself leaves a Principled BSDF's negative emission out; an Emission node's it
    # bakes negative.
    assert ("'shining' (material 'shine') emits negative light in places (a negative "
            "emission strength): raised to 0; set it to 0 or more") in job.warnings
    assert not any(w.startswith("'glowing'") for w in job.warnings)
    assert any(w.startswith("light 'sink' has a negative power") for w in job.warnings)
    out = job.export.scene
    assert min(texture.min() for texture in out.emission_textures + out.albedo_textures) >= 0.0
    assert [l.name for l in out.lights] == ["lamp"]
    assert bpy.ops.luxel.bake() == {'FINISHED'}


def test_albedo_of_one_or_more_is_clamped_and_the_energy_stays_bounded():
    scene = fast(room_scene())
    scene.luxel.max_shots = 300         # albedo 0.999 in a closed room barely converges
    walls = bpy.data.materials["walls"].node_tree.nodes["Principled BSDF"]
    walls.inputs["Base Color"].default_value = (1.5, 1.0, 3.0, 1.0)
    walls.inputs["Specular IOR Level"].default_value = 0.0
    job = addon.bake.BakeJob(bpy.context)
    try:
        job.set_up()
        assert ("'room' (material 'walls') reflects more than 0.999 of the light in places "
                "(a colour of 1 or more): lowered to 0.999, since a surface cannot reflect "
                "all light") in job.warnings
        assert max(page.max() for page in job.export.scene.albedo_textures) == pytest.approx(0.999)
        while not job.step(1.0):
            pass
        ledger = job.solver.ledger()
        pages = job.solver.result()
    finally:
        job.release()
    # Reflecting 99.9 %, the room keeps most of the light unshot, but none is made.
    assert (0.0 <= ledger.absorbed).all() and (ledger.absorbed < ledger.emitted).all()
    assert (0.0 <= ledger.unshot).all() and (ledger.unshot < ledger.emitted).all()
    assert ledger.imbalance() < 1e-3
    assert all(np.isfinite(page).all() for page in pages)


# ------------------------------------------------------------------------------- lights
def test_only_zero_strength_lights_and_emission_are_refused_as_no_light():
    scene = fast(room_scene(with_light=False))
    light(scene, "off", 'POINT', (0, 0, 3), energy=0.0)
    light(scene, "dark sun", 'SUN', (0, 0, 3), energy=0.0)
    light(scene, "black", 'SPOT', (0, 0, 3), energy=100.0, colour=(0.0, 0.0, 0.0))
    cube(scene, "unlit lamp", 0.3, (0, 0, 3.5),
         material("dim", (0.5, 0.5, 0.5), emission=(1.0, 1.0, 1.0), strength=0.0))
    before = blend_state(scene)
    message = bake_error("no light")
    assert "add a light with positive power" in message
    assert blend_state(scene) == before


# ------------------------------------------------------------------------ texel density
def test_a_texel_density_of_zero_cannot_be_set_and_is_refused_on_the_command_line(capsys):
    scene = room_scene()
    scene.luxel.texel_density = 0.0
    assert scene.luxel.texel_density == pytest.approx(0.01)   # the property's minimum
    for value, problem in (("0", "must be at least 0.01 texels per metre"),
                           ("0.0099", "must be at least 0.01 texels per metre"),
                           ("-3", "must be at least 0.01 texels per metre"),
                           ("nan", "must be a finite number"), ("inf", "must be a finite number")):
        assert run_cli(["bake", "--density", value]) == 2, value
        assert f"argument --density: {problem}" in one_line(capsys), value
    assert not scene.luxel.stats.valid


@pytest.fixture
def memory_limit(monkeypatch):
    """The GPU memory Luxel may use, lowered so that a fitting density bakes in a second."""
    limit = 4 << 20
    settings_class = type(bpy.context.scene.luxel)
    original = settings_class.solver_settings
    monkeypatch.setattr(settings_class, "solver_settings",
                        lambda self: replace(original(self), memory_limit=limit))
    return limit


def bakes_at_the_suggested_density(scene, message):
    """The density the message suggests bakes (a few shots: fitting is the point)."""
    scene.luxel.texel_density = float(re.search(
        r"texel density (?:from \S+ )?to ([0-9.e+]+) texels per metre", message).group(1))
    scene.luxel.max_shots = 20
    return bpy.ops.luxel.bake() == {'FINISHED'}


def test_an_absurd_texel_density_names_the_memory_needed_and_a_density_that_fits(
        memory_limit, monkeypatch):
    scene = fast(room_scene())
    scene.luxel.texel_density = 1e6
    before = blend_state(scene)
    charted = []
    original = native.set_up.build_atlas
    monkeypatch.setattr(native.set_up, "build_atlas", lambda scene, density, *args, **kwargs:
                        charted.append(density) or original(scene, density, *args, **kwargs))
    message = bake_error("GPU memory")
    assert max(charted) < 1e3, "refused before xatlas charts the surface at 10^6 texels/m"
    assert "but 4.0 MiB are allowed" in message and "MiB of GPU memory" in message
    assert blend_state(scene) == before
    assert bakes_at_the_suggested_density(scene, message)


def test_a_density_just_over_the_memory_is_refused_by_the_solvers_own_check(memory_limit):
    scene = fast(room_scene())
    area = sum(p.area for obj in scene.objects if obj.type == 'MESH' for p in obj.data.polygons)
    bytes_per_texel = luxel.native.solver.BYTES_PER_TEXEL
    scene.luxel.texel_density = 0.95 * math.sqrt(memory_limit / (area * bytes_per_texel))
    before = blend_state(scene)
    message = bake_error("GPU memory")
    assert "MiB are allowed" in message       # the solver measured the atlas itself
    assert blend_state(scene) == before
    assert bakes_at_the_suggested_density(scene, message)


def test_an_absurd_density_on_the_command_line_fails_with_one_line(capsys):
    scene = room_scene()
    assert run_cli(["bake", "--density", "1e6"]) == 1
    line = one_line(capsys)
    assert "MiB of GPU memory" in line and "texels per metre or less" in line
    assert not scene.luxel.stats.valid


# ------------------------------------------------------------------------------ OpenGL
def test_no_opengl_says_how_to_get_one_and_changes_nothing(monkeypatch):
    scene = fast(room_scene())

    def no_driver(*args, **kwargs):
        raise Exception("libEGL.so: cannot open shared object file")

    monkeypatch.setattr(moderngl, "create_standalone_context", no_driver)
    before = blend_state(scene)
    message = bake_error("OpenGL 4.1")
    assert "apt install libegl1 libgl1-mesa-dri" in message
    assert blend_state(scene) == before


# ---------------------------------------------------------------- cancel and failures
MOMENTS = ("before the first step", "after some steps", "after the last step")


@pytest.mark.parametrize("moment", MOMENTS)
@pytest.mark.parametrize("rebake", (False, True), ids=("first bake", "re-bake"))
def test_cancel_at_any_moment_leaves_the_file_as_it_was(moment, rebake):
    scene = fast(room_scene())
    if rebake:
        bpy.ops.luxel.bake()
        scene.objects["block"].location.x -= 0.2
    before = blend_state(scene)
    job = addon.bake.BakeJob(bpy.context)
    job.set_up()
    if moment == "after some steps":
        job.step(0.2)
    elif moment == "after the last step":
        while not job.step(1.0):
            pass
    job.release()           # what Esc does in the modal operator
    assert released(job)
    assert blend_state(scene) == before


def test_esc_in_the_modal_bake_cancels_frees_the_gpu_and_changes_nothing():
    scene = fast(room_scene())
    bpy.ops.luxel.bake()
    before = blend_state(scene)
    driver = OperatorDriver()
    driver.start_modal()
    assert driver.event('TIMER') == {'RUNNING_MODAL'}
    while not driver._job.is_set_up:
        assert driver.event('TIMER') == {'RUNNING_MODAL'}
    assert driver.event('MOUSEMOVE') == {'PASS_THROUGH'}
    assert driver.event('ESC') == {'CANCELLED'}
    assert driver.reports == [('WARNING', "Luxel bake cancelled; nothing was changed")]
    assert released(driver._job) and not LUXEL_OT_bake._modal_running
    assert blend_state(scene) == before


def test_the_modal_bake_driven_by_timer_events_finishes_like_execute():
    scene = fast(room_scene())
    driver = OperatorDriver()
    driver.start_modal()
    for _ in range(1000):
        result = driver.event('TIMER')
        if result != {'RUNNING_MODAL'}:
            break
    assert result == {'FINISHED'} and not LUXEL_OT_bake._modal_running
    assert scene.luxel.stats.valid and released(driver._job)


@pytest.fixture
def one_piece_per_event(monkeypatch):
    """Each timer event does one piece of the set-up, and each piece of the export one
    object: Esc can come between any two."""
    monkeypatch.setattr(addon.operators, "STEP_SECONDS", 0.0)
    monkeypatch.setattr(addon.export, "EXPORT_PIECE_SECONDS", 0.0)


def events_into(driver, stage, pieces):
    """Timer events until ``pieces`` of the set-up's ``stage`` are done (0: it is named next)."""
    done = 0
    while not (driver._job.set_up_progress.stage == stage and done == pieces):
        done += driver._job.set_up_progress.stage == stage
        assert driver.event('TIMER') == {'RUNNING_MODAL'}
        assert not driver._job.is_set_up, f"the set-up ended before {pieces} of {stage}"


@pytest.mark.parametrize("stage, pieces", (("exporting the scene", 1),
                                           ("opening OpenGL", 0),
                                           ("charting", 0), ("preprocessing", 1)))
def test_esc_in_each_set_up_stage_cancels_and_changes_nothing(one_piece_per_event, stage,
                                                              pieces):
    scene = fast(room_scene())
    bpy.ops.luxel.bake()
    scene.objects["block"].location.x -= 0.2
    before = blend_state(scene)
    driver = OperatorDriver()
    driver.start_modal()
    events_into(driver, stage, pieces)
    job = driver._job
    if stage == "exporting the scene":
        assert 0.0 < job.set_up_progress.fraction < 0.5
        # The export reads the scene: edits wait.
        assert driver.event('MOUSEMOVE') == {'RUNNING_MODAL'}
    if stage == "preprocessing":
        assert job.solver.gl_object_count > 0     # maps on the GPU to free
    assert driver.event('ESC') == {'CANCELLED'}
    assert driver.reports == [('WARNING', "Luxel bake cancelled; nothing was changed")]
    assert released(job) and not LUXEL_OT_bake._modal_running
    assert blend_state(scene) == before


def test_the_modal_bake_names_each_set_up_stage_and_its_progress_moves_forward(
        one_piece_per_event):
    fast(room_scene())
    driver = OperatorDriver()
    driver.start_modal()
    stages = []
    while not driver._job.is_set_up:
        assert driver.event('TIMER') == {'RUNNING_MODAL'}
        stages.append((driver._job.set_up_progress.stage, driver.progress[-1]))
    for _ in range(3):
        assert driver.event('TIMER') == {'RUNNING_MODAL'}
    assert driver.event('ESC') == {'CANCELLED'}
    named = [stage for stage, _ in itertools.groupby(stage for stage, _ in stages)]
    assert named == ["exporting the scene", "evaluating the materials with Cycles",
                     "opening OpenGL", "charting",
                     "preprocessing"]
    assert driver.progress == sorted(driver.progress) and driver.progress[-1] > 0
    first = {stage: value for stage, value in reversed(stages)}
    assert 0 < first["exporting the scene"] < first["charting"] < first["preprocessing"]
    shown = [text for text in driver.status if text]
    for stage in named:
        assert any(text.startswith(f"Luxel: {stage}") and text.endswith("(Esc to cancel)")
                   for text in shown), stage
    assert any("charting (xatlas cannot be interrupted" in text for text in shown)
    assert " shots, " in shown[-1]


SOLVER_FAILURES = (native.GLUnavailableError("the GL context was lost"),
                   RuntimeError("GL_OUT_OF_MEMORY"))


@pytest.mark.parametrize("error", SOLVER_FAILURES, ids=lambda e: type(e).__name__)
def test_a_solver_failure_mid_bake_is_reported_and_changes_nothing(monkeypatch, error):
    scene = fast(room_scene())
    bpy.ops.luxel.bake()
    scene.objects["block"].location.x -= 0.2
    before = blend_state(scene)
    failing = FailingSteps(monkeypatch, error)
    message = bake_error(re.escape(str(error)))
    if not isinstance(error, native.LuxelError):
        assert message.startswith("Error: the GPU solver failed (RuntimeError: GL_OUT_OF_MEMORY)"
                                  "; the file was left as it was. Bake again; if it fails again,"
                                  " update the GPU driver")
    assert failing.all_released() and not LUXEL_OT_bake._modal_running
    assert blend_state(scene) == before


@pytest.mark.parametrize("entry", ("execute", "modal"))
@pytest.mark.parametrize("error", SOLVER_FAILURES, ids=lambda e: type(e).__name__)
def test_a_solver_failure_reports_an_error_and_returns_cancelled(monkeypatch, error, entry):
    scene = fast(room_scene())
    before = blend_state(scene)
    failing = FailingSteps(monkeypatch, error)
    driver = OperatorDriver()
    if entry == "execute":
        assert driver.execute(bpy.context) == {'CANCELLED'}
    else:
        driver.start_modal()
        while not driver._job.is_set_up:
            assert driver.event('TIMER') == {'RUNNING_MODAL'}
        # Each timer event steps for a time budget: on a busy machine the failing step may
        # come a few events later.
        results = [driver.event('TIMER') for _ in range(failing.after + 2)
                   if LUXEL_OT_bake._modal_running]
        assert results[-1] == {'CANCELLED'}
        assert all(result == {'RUNNING_MODAL'} for result in results[:-1])
    assert [kind for kind, _ in driver.reports] == ['ERROR']
    assert str(error) in driver.reports[0][1]
    assert failing.all_released() and not LUXEL_OT_bake._modal_running
    assert blend_state(scene) == before


@pytest.mark.parametrize("output", ("PACK", "FILES"))
@pytest.mark.parametrize("rebake", (False, True), ids=("first bake", "re-bake"))
def test_a_failure_midway_through_writing_back_undoes_everything(monkeypatch, tmp_path, output,
                                                                  rebake):
    scene = fast(room_scene())
    scene.luxel.output = output
    scene.luxel.directory = str(tmp_path / "maps")
    if rebake:
        bpy.ops.luxel.bake()
        scene.objects["block"].location.x -= 0.2
    before = blend_state(scene, tmp_path / "maps")
    writeback = addon.writeback
    original, calls = writeback._write_uv_map, []

    def write_then_fail(*args):
        original(*args)
        calls.append(args[0].name)
        if len(calls) == 2:         # the images and two UV maps are made: fail now
            raise MemoryError("simulated")

    monkeypatch.setattr(writeback, "_write_uv_map", write_then_fail)
    message = bake_error("writing the lightmaps failed \\(MemoryError: simulated\\)")
    assert "the file was left as it was" in message and len(calls) == 2
    assert blend_state(scene, tmp_path / "maps") == before
    assert rebake or not (tmp_path / "maps").exists()


# --------------------------------------------------------------------- command line output
def test_an_output_folder_that_cannot_be_written_fails_before_the_bake(tmp_path, capsys):
    scene = room_scene()
    blocker = tmp_path / "a file"
    blocker.write_text("not a folder")
    for folder in (blocker, blocker / "maps"):
        assert run_cli(["bake", "--density", "4", "--output", str(folder)]) == 1
        line = one_line(capsys)
        assert f"the lightmap folder '{folder}' cannot be written" in line
        assert "choose a folder you may write to" in line
    assert os.listdir(tmp_path) == ["a file"] and blocker.read_text() == "not a folder"
    assert not scene.luxel.stats.valid and not bpy.data.images


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc")
def test_an_output_folder_that_takes_no_file_fails_before_the_bake(capsys):
    """/proc lets root pass a permission check, and takes no file: the folder is tried with
    a file before the bake, not found after it (the message asked to report a bug)."""
    scene = room_scene()
    for folder in ("/proc/luxel-maps", "/proc/self"):
        assert run_cli(["bake", "--density", "4", "--output", folder]) == 1
        assert f"the lightmap folder '{folder}' cannot be written" in one_line(capsys)
    assert not scene.luxel.stats.valid and not bpy.data.images


def test_save_as_writes_a_new_file_and_leaves_the_open_one_as_it_was(tmp_path, capsys):
    """--save-as (the render farm's save) writes the baked scene once, as a new file in a
    folder it makes, and no backup (.blend1) beside it; the .blend that was opened keeps
    its bytes; a name that is not a .blend or a place that takes no file is refused before
    the bake."""
    room_scene()
    original = tmp_path / "room.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(original))
    before = original.read_bytes()
    (tmp_path / "a file").write_text("not a folder")
    for target, problem in (("copy.txt", "name a .blend file"),
                            (str(tmp_path / "a file" / "copy.blend"), "cannot be written")):
        assert run_cli(["bake", "--density", "4", "--save-as", target]) == 2
        assert problem in one_line(capsys)
    copy = tmp_path / "bakes" / "1-room" / "room.blend"
    assert run_cli(["bake", "--density", "4", "--threshold", "0.05", "--output",
                    str(copy.parent), "--save-as", str(copy)]) == 0
    assert f"luxel: saved {copy}" in capsys.readouterr().out
    assert sorted(p.name for p in copy.parent.iterdir()) == ["Luxel_Scene_0.exr",
                                                              "Luxel_Scene_0_Irradiance.exr",
                                                              "room.blend"]
    assert original.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a file", "bakes", "room.blend"]
    bpy.ops.wm.open_mainfile(filepath=str(copy))
    room = bpy.context.scene.objects["room"]
    assert room.luxel.image is not None and room.luxel.uv_map in room.data.uv_layers


def blender_command(*arguments):
    """tools/blender.py (Blender's command line for the bpy module) run with ``arguments``."""
    return subprocess.run([sys.executable, str(blender_session.ROOT / "tools" / "blender.py"),
                           *map(str, arguments)], capture_output=True, text=True, timeout=300)


def test_a_render_farms_command_line_bakes_and_bad_files_fail_in_one_line(tmp_path):
    """What Flamenco runs (its default -b -y, a Python expression run first with
    --python-exit-code, the file, --command last) bakes through tools/blender.py; a .blend
    that does not exist, a file that is not one and an option Blender has that bakes do not
    use each end in one line and a non-zero exit, not a traceback."""
    room_scene()
    scene_file = tmp_path / "room.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(scene_file))
    not_a_blend = tmp_path / "notes.blend"
    not_a_blend.write_text("not a .blend")
    for arguments, code, message in (
            (["-b", "-y", tmp_path / "missing.blend"], 1, "cannot open"),
            (["-b", "-y", not_a_blend], 1, "cannot open"),
            (["-b", "--render-anim", scene_file], 2, "--render-anim is not taken here")):
        result = blender_command(*arguments, "--command", "luxel", "bake")
        assert result.returncode == code
        lines = [line for line in result.stderr.splitlines() if line.strip()]
        assert message in lines[-1] and "Traceback" not in result.stderr
    folder = tmp_path / "bakes" / "1-room"
    result = blender_command(
        "-b", "-y", scene_file, "--python-exit-code", "1", "--python-expr",
        "import bpy; assert bpy.data.filepath.endswith('room.blend')", "--command", "luxel",
        "bake", "--density", "4", "--threshold", "0.05", "--output", folder,
        "--save-as", folder / "room.blend")
    assert result.returncode == 0, result.stderr
    assert sorted(p.name for p in folder.iterdir()) == ["Luxel_Scene_0.exr",
                                                        "Luxel_Scene_0_Irradiance.exr",
                                                        "room.blend"]
    # A log a farm keeps: Luxel's lines and Blender's reading and saving the file, nothing
    # that reads as an error (Cycles' temporary bakes printed a line each).
    assert "Baking map saved" not in result.stdout and not result.stderr.strip()
    assert all(line.startswith("luxel: ") or " | " in line or line.startswith("Info: Saved")
               for line in result.stdout.splitlines() if line.strip()), result.stdout
    failing = blender_command("-b", scene_file, "--python-exit-code", "5", "--python-expr",
                              "raise RuntimeError('stop here')", "--command", "luxel", "bake")
    assert failing.returncode == 5 and "stop here" in failing.stderr


def test_a_blend_named_on_the_command_line_that_did_not_open_is_refused(tmp_path):
    """Blender goes on with its startup scene when it cannot read the .blend it was given:
    a farm would bake the default cube. The command line names it."""
    blender_session.empty_file()
    argv = ["blender", "-b", "-y", "/shots/missing.blend", "--command", "luxel", "bake"]
    assert addon.cli._unopened_blend(argv) == "/shots/missing.blend"
    assert addon.cli._unopened_blend(argv[:3] + argv[4:]) is None
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "opened.blend"))
    assert addon.cli._unopened_blend(argv) is None


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write into a read-only folder")
def test_a_read_only_output_folder_fails_before_the_bake(tmp_path, capsys):
    room_scene()
    folder = tmp_path / "read only"
    folder.mkdir(mode=0o555)
    assert run_cli(["bake", "--density", "4", "--output", str(folder)]) == 1
    assert f"'{folder}' cannot be written" in one_line(capsys)
    assert os.listdir(folder) == []


def fill_the_disk_at_file(monkeypatch, number):
    """OpenEXR.File writes ``number`` - 1 files, then puts part of the next one down and finds
    the disk full."""
    real, opened = OpenEXR.File, []

    class File:
        def __init__(self, *args):
            opened.append(args)
            self.args = args

        def write(self, name):
            if len(opened) < number:
                return real(*self.args).write(name)
            with open(name, "wb") as file:
                file.write(b"v/1\x01" + bytes(100))
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(OpenEXR, "File", File)


@pytest.mark.parametrize("rebake", (False, True), ids=("first bake", "re-bake"))
def test_a_disk_filling_up_while_writing_exr_leaves_no_file_and_no_saved_blend(
        monkeypatch, tmp_path, capsys, rebake):
    scene = room_scene()
    # Two pages at 5 texels per metre: the block's charts, finer, do not fit beside the room's.
    scene.luxel.max_atlas_size = 64
    scene.objects["block"].luxel.resolution_scale = 3.0
    blend = tmp_path / "room.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    maps = tmp_path / "maps"
    settings = ["--density", "5", "--shots", "30", "--output", str(maps), "--save"]
    if rebake:
        assert run_cli(["bake", *settings]) == 0
        assert sorted(os.listdir(maps)) == ["Luxel_Scene_0.exr", "Luxel_Scene_0_Irradiance.exr",
                                            "Luxel_Scene_1.exr", "Luxel_Scene_1_Irradiance.exr"]
        scene.objects["block"].location.x -= 0.2
    capsys.readouterr()
    saved = blend.read_bytes()
    before = blend_state(scene, maps)
    fill_the_disk_at_file(monkeypatch, 2)
    assert run_cli(["bake", *settings]) == 1
    line = one_line(capsys)
    assert f"could not write the lightmap '{maps / 'Luxel_Scene_1.exr'}' (No space left on " \
           "device): free some disk space" in line
    assert blend_state(scene, maps) == before       # no temporary or staged file either
    assert rebake or not maps.exists()
    assert blend.read_bytes() == saved


# ------------------------------------------------------------------------ the shot limit
class LabelRecorder:
    """Stands in for a panel's UILayout: records the texts of its labels."""

    def __init__(self, labels=None):
        self.labels = [] if labels is None else labels

    def column(self, **_):
        return LabelRecorder(self.labels)

    row = column

    def label(self, text="", **_):
        self.labels.append(text)

    def prop(self, *_, **__):
        pass

    operator = prop


def last_bake_labels(scene):
    layout = LabelRecorder()
    addon.panels.LUXEL_PT_render_stats.draw(SimpleNamespace(layout=layout),
                                            SimpleNamespace(scene=scene))
    return layout.labels


STOPPED = re.compile(r"stopped at the shot limit \(12 shots\) with ([0-9.]+) % unshot")


def test_a_bake_stopped_at_the_shot_limit_says_so_with_the_unshot_share(capsys):
    scene = room_scene()
    scene.luxel.texel_density, scene.luxel.threshold, scene.luxel.max_shots = 5.0, 0.001, 12
    driver = OperatorDriver()
    assert driver.execute(bpy.context) == {'FINISHED'}
    stats = scene.luxel.stats
    assert stats.shots == 12 and stats.stopped_at_shot_limit
    assert stats.unshot > 100.0 * 0.001         # the threshold was not reached
    stopped = [(kind, message) for kind, message in driver.reports if STOPPED.search(message)]
    assert len(stopped) == 1 and stopped[0][0] == 'WARNING'
    assert float(STOPPED.search(stopped[0][1]).group(1)) == pytest.approx(stats.unshot,
                                                                          abs=0.01)
    assert "raise Max Shots" in stopped[0][1]
    assert any(label.startswith("Stopped at the shot limit") and label.endswith("% unshot")
               for label in last_bake_labels(scene))

    assert run_cli(["bake", "--density", "5", "--threshold", "0.001", "--shots", "12"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"luxel: warning: Luxel " + STOPPED.pattern + r".*raise --shots", out)


def test_a_converged_bake_does_not_mention_the_shot_limit(capsys):
    scene = fast(room_scene())
    driver = OperatorDriver()
    assert driver.execute(bpy.context) == {'FINISHED'}
    assert scene.luxel.stats.valid and not scene.luxel.stats.stopped_at_shot_limit
    assert scene.luxel.stats.unshot <= 100.0 * scene.luxel.threshold
    assert not any("shot limit" in message for _, message in driver.reports)
    assert not any("shot limit" in label for label in last_bake_labels(scene))
    assert run_cli(["bake"]) == 0
    out = capsys.readouterr().out
    assert "luxel: done" in out and "shot limit" not in out
    # The set-up's stages, in order, before the shots.
    assert (out.index("luxel: opening OpenGL") < out.index("luxel: charting")
            < out.index("luxel: preprocessing") < out.index(" triangles, ")
            < out.index("luxel: done"))
    # A log for the background: no Esc to name, and Luxel's lines all begin "luxel: ".
    assert "Esc" not in out and "Luxel: " not in out


def pixel_values(image):
    values = np.empty(len(image.pixels), dtype=np.float32)
    image.pixels.foreach_get(values)
    return values.reshape(-1, 4)


def test_a_bake_whose_shots_make_light_keeps_its_last_good_lightmaps_and_says_so(
        capsys, monkeypatch):
    """Shots that deliver their light twice after the first 150 (as a defect would): the
    unshot power rises, and the bake stops with the lightmaps of its last checkpoint. The
    operator warns, the panel says so, and the command line exits 3 with one line on stderr;
    the lightmaps written are finite and no brighter than those of a sound bake of the same
    room to its threshold (every partial solution lies under the converged one)."""
    scene = fast(room_scene())
    scene.luxel.threshold = 0.001
    assert run_cli(["bake"]) == 0
    prefix = addon.writeback.image_name(scene, "")
    sound_images = {image.name: pixel_values(image) for image in bpy.data.images
                    if image.name.startswith(prefix)}
    assert sound_images
    capsys.readouterr()

    delivered = native.receivers.update
    calls = []

    def twice_after_150(*args, **kwargs):
        calls.append(1)
        delivered(*args, **kwargs)
        if len(calls) > 150:
            delivered(*args, **kwargs)

    monkeypatch.setattr(native.receivers, "update", twice_after_150)
    driver = OperatorDriver()
    assert driver.execute(bpy.context) == {'FINISHED'}
    stats = scene.luxel.stats
    assert stats.diverged and not stats.stopped_at_shot_limit
    warned = [message for kind, message in driver.reports
              if kind == 'WARNING' and "made light" in message]
    assert len(warned) == 1 and f"{stats.unshot:.2f} % unshot" in warned[0]
    assert "Stopped: the unshot power rose" in last_bake_labels(scene)
    for name, image in sound_images.items():
        kept = pixel_values(bpy.data.images[name])
        assert np.isfinite(kept).all()
        assert kept[:, :3].sum() <= image[:, :3].sum() * 1.001

    calls.clear()
    assert run_cli(["bake"]) == addon.cli.EXIT_DIVERGED
    assert "made light" in one_line(capsys)
