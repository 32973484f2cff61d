"""Bad input gets a typed error naming the object and the fix; output files are sound."""
from dataclasses import fields
import os

import numpy as np
import pytest

import analytic
import scenes
from native import (GLUnavailableError, GPUMemoryError, PointLight, Scene, SceneError,
                    Settings, SettingsError, Solver, SpotLight, SunLight, read_exr, tone_map,
                    write_exr, write_png)
from native.samples import SceneBuilder, cornell_box


def two_quads(**overrides):
    builder = SceneBuilder()
    builder.quad("Floor", scenes.RECEIVER, (0.5, 0.5, 0.5))
    builder.quad("Lamp", scenes.CEILING, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    scene = builder.build()
    fields = dict(vertices=scene.vertices, triangles=scene.triangles, albedo=scene.albedo,
                  emission=scene.emission, object_index=scene.object_index,
                  object_names=scene.object_names)
    fields.update(overrides)
    return fields


def test_nan_vertex_names_the_object():
    fields = two_quads()
    fields["vertices"] = fields["vertices"].copy()
    fields["vertices"][5, 1] = np.nan
    with pytest.raises(SceneError, match="Lamp") as error:
        Scene(**fields)
    assert error.value.object_name == "Lamp"
    assert "not finite" in str(error.value)


def test_albedo_of_one_or_more_is_refused_with_the_fix():
    fields = two_quads()
    fields["albedo"] = fields["albedo"].copy()
    fields["albedo"][0] = (1.0, 0.5, 0.5)
    with pytest.raises(SceneError, match=r"Floor.*below 1"):
        Scene(**fields)


def test_degenerate_triangle_is_refused():
    fields = two_quads()
    fields["vertices"] = fields["vertices"].copy()
    triangle = fields["triangles"][2]
    fields["vertices"][triangle[2]] = fields["vertices"][triangle[1]]
    with pytest.raises(SceneError, match="degenerate"):
        Scene(**fields)


def test_scene_without_light_is_refused():
    fields = two_quads(emission=np.zeros((4, 3)))
    with pytest.raises(SceneError, match="no light"):
        Scene(**fields)
    fields["lights"] = [PointLight(position=(0, 0, 1), power=0.0)]
    with pytest.raises(SceneError, match="no light"):
        Scene(**fields)


def test_negative_emission_and_bad_lights_are_refused():
    with pytest.raises(SceneError, match="negative"):
        Scene(**two_quads(emission=-np.ones((4, 3))))
    with pytest.raises(SceneError, match="Spotty"):
        Scene(**two_quads(lights=[SpotLight(position=(0, 0, 1), direction=(0, 0, 0),
                                            power=1.0, name="Spotty")]))


def test_bad_settings_are_refused(ctx):
    scene = Scene(**two_quads())
    with pytest.raises(SettingsError, match="texel_density"):
        Solver(scene, Settings(texel_density=0.0), ctx=ctx)
    with pytest.raises(SettingsError, match="shoot_level"):
        Solver(scene, Settings(shoot_level=9), ctx=ctx)


def test_too_many_texels_reports_memory_and_a_density_that_fits(ctx, gl_clean):
    scene = cornell_box()
    limit = 2 << 20
    with pytest.raises(GPUMemoryError) as error:
        Solver(scene, Settings(texel_density=400.0, memory_limit=limit), ctx=ctx)
    assert error.value.needed_bytes > limit == error.value.available_bytes
    assert "texels per metre" in str(error.value)
    suggested = error.value.suggested_density
    assert 0 < suggested < 400
    solver = Solver(scene, Settings(texel_density=suggested, memory_limit=limit), ctx=ctx)
    assert solver.gpu_memory_bytes <= limit
    solver.release()


def test_a_large_hemicube_bakes_and_a_map_too_large_is_refused_by_name(ctx, gl_clean):
    """A batch's visibility maps are one texture: at Hemicube Resolution 2048 eight shooters'
    cubes would be 1.5 GiB, and OpenGL left its framebuffer incomplete. The batch is cut to
    what one texture holds, and the bake matches the closed form; a hemisphere map that no
    batch makes small enough is refused naming the setting and a value that fits."""
    radiance, albedo = np.array([1.0, 1.0, 1.0]), 0.5
    with Solver(scenes.parallel_squares(radiance, albedo),
                Settings(texel_density=8, hemicube_resolution=2048, threshold=0.001,
                         ambient=False), ctx=ctx) as solver:
        solver.run()
        image, samples = solver.result()[0], solver.texel_samples()[0]
    on_receiver = (samples["occupied"] & (np.abs(samples["position"][..., 2]) < 1e-5)
                   & (samples["normal"][..., 2] > 0.99))
    area = samples["area"][on_receiver]
    mean = (image[on_receiver, :3] * area[:, None]).sum(axis=0) / area.sum()
    truth = albedo * radiance * analytic.parallel_squares_form_factor(1, 1)
    np.testing.assert_allclose(mean, truth, rtol=0.01)
    assert ctx.error == "GL_NO_ERROR"
    with pytest.raises(SettingsError, match="Hemicube Resolution 4096.*set it to 2048"):
        Solver(scenes.parallel_squares(radiance, albedo),
               Settings(projection="HEMISPHERE", hemicube_resolution=4096), ctx=ctx)


def test_an_absurd_density_is_refused_before_xatlas_charts_it(ctx, gl_clean, monkeypatch):
    """At 10^6 texels per metre xatlas would chart for hours; the surface area alone shows
    the memory would not do, and the density suggested is one whose atlas was checked."""
    import native.set_up
    charted = []
    original = native.set_up.build_atlas
    monkeypatch.setattr(native.set_up, "build_atlas", lambda scene, density, *args, **kwargs:
                        charted.append(density) or original(scene, density, *args, **kwargs))
    limit = 2 << 20
    with pytest.raises(GPUMemoryError) as error:
        Solver(cornell_box(), Settings(texel_density=1e6, memory_limit=limit), ctx=ctx)
    assert max(charted) < 1e3
    assert error.value.needed_bytes > 1000 * limit
    assert charted[-1] == error.value.suggested_density
    solver = Solver(cornell_box(), Settings(texel_density=error.value.suggested_density,
                                            memory_limit=limit), ctx=ctx)
    assert solver.gpu_memory_bytes <= limit
    solver.release()


def test_no_opengl_says_what_to_install(monkeypatch):
    import moderngl

    def no_driver(*args, **kwargs):
        raise Exception("libEGL.so: cannot open shared object file")

    monkeypatch.setattr(moderngl, "create_standalone_context", no_driver)
    with pytest.raises(GLUnavailableError, match="Mesa"):
        Solver(Scene(**two_quads()))


def test_exr_round_trip_and_atomic_write(tmp_path):
    image = np.random.default_rng(1).random((7, 11, 4)).astype(np.float32) * 50
    path = tmp_path / "page0.exr"
    write_exr(path, image)
    np.testing.assert_array_equal(read_exr(path), image)
    assert os.listdir(tmp_path) == ["page0.exr"]


def test_failed_write_leaves_no_file(tmp_path, monkeypatch):
    import OpenEXR

    class Broken:
        def __init__(self, *args):
            pass

        def write(self, name):
            open(name, "wb").write(b"partial")
            raise OSError("No space left on device")

    monkeypatch.setattr(OpenEXR, "File", Broken)
    with pytest.raises(OSError, match="space"):
        write_exr(tmp_path / "page0.exr", np.zeros((2, 2, 4), np.float32))
    assert os.listdir(tmp_path) == []


def test_png_preview_is_a_valid_image(tmp_path):
    import zlib
    image = np.zeros((3, 5, 4), np.float32)
    image[0, 0, :3] = 100.0
    rgb = tone_map(image)
    assert rgb.shape == (3, 5, 3) and rgb.dtype == np.uint8
    assert rgb[0, 0].min() > 200 and rgb[1, 1].max() == 0
    path = tmp_path / "preview.png"
    write_png(path, rgb)
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    idat = data.index(b"IDAT")
    length = int.from_bytes(data[idat - 4:idat], "big")
    raw = zlib.decompress(data[idat + 4:idat + 4 + length])
    assert len(raw) == 3 * (1 + 5 * 3)


def test_written_files_get_the_usual_permissions(tmp_path):
    umask = os.umask(0o022)
    try:
        write_exr(tmp_path / "page0.exr", np.zeros((2, 2, 4), np.float32))
    finally:
        os.umask(umask)
    assert (tmp_path / "page0.exr").stat().st_mode & 0o777 == 0o644


def test_scene_save_and_load_round_trip_every_field(tmp_path):
    rng = np.random.default_rng(2)
    scene = Scene(**two_quads(
        normals=np.tile((0.0, 0.0, 1.0), (8, 1)),
        emission_two_sided=[True, True, False, False], receive=[True, True, False, False],
        occlude=[True, True, False, False], object_texel_scale=[2.0, 0.5],
        albedo_uv=rng.random((4, 3, 2)), albedo_texture_index=[0, 1, -1, -1],
        albedo_textures=[rng.random((3, 5, 3)) * 0.9, rng.random((2, 2, 4)) * 0.9],
        lights=[PointLight(position=(0.1, 0.2, 0.9), power=5.0, color=(1.0, 0.5, 0.25)),
                SpotLight(position=np.array([0.5, 0.5, 0.8]), power=8.0, spot_size=0.7,
                          spot_blend=0.3, direction=(0.0, 0.1, -1.0), name="Spotty"),
                SunLight(direction=(0.2, -0.3, -1.0), strength=2.0, name="Sunny")],
        sky=(0.01, 0.02, 0.03)))
    path = tmp_path / "scene.npz"
    scene.save(path)
    loaded = Scene.load(path)
    for field in fields(Scene):
        original, restored = getattr(scene, field.name), getattr(loaded, field.name)
        if field.name == "lights":
            assert [type(light) for light in restored] == [type(light) for light in original]
            for a, b in zip(original, restored):
                for key, value in vars(a).items():
                    assert np.array_equal(np.asarray(getattr(b, key)), np.asarray(value)), key
        elif field.name == "albedo_textures":
            assert len(restored) == len(original)
            for a, b in zip(original, restored):
                np.testing.assert_array_equal(b, a)
        elif isinstance(original, list):
            assert restored == original, field.name
        else:
            np.testing.assert_array_equal(restored, original, err_msg=field.name)


def test_scene_without_normals_or_textures_loads_the_same(tmp_path):
    scene = cornell_box()
    scene.save(tmp_path / "box.npz")
    loaded = Scene.load(tmp_path / "box.npz")
    assert loaded.normals is None and loaded.albedo_uv is None and loaded.albedo_textures == []
    np.testing.assert_array_equal(loaded.triangle_area, scene.triangle_area)


def test_preview_culls_only_faces_that_have_a_mirrored_copy(ctx, gl_clean):
    """A floor seen from below hides the two-sided light above it in the preview: only a
    triangle with a mirrored copy (here the light's) and the copy are drawn from the front
    alone. The centre pixel shows the floor's lightmap (rho E / pi, below 0.5 x 10 / pi x
    F < 1.6), not the light's radiance of 10."""
    from native.preview import render_preview
    builder = SceneBuilder()
    builder.quad("floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], (0.5,) * 3)
    builder.quad("light", [(-.3, -.3, 1), (-.3, .3, 1), (.3, .3, 1), (.3, -.3, 1)], (0.0,) * 3,
                 (10.0,) * 3, two_sided=True)
    solver = Solver(builder.build(), Settings(texel_density=10, max_shots=20), ctx=ctx)
    try:
        assert solver.scene.back_of is not None   # the light has its copy
        solver.run()
        view = render_preview(solver, solver.result(), eye=(0.0, 0.0, -2.0),
                              target=(0.0, 0.0, 0.0), fov=20.0, size=(16, 16), supersample=1)
        centre = view[8, 8]
        assert 0.0 < centre.max() < 1.6
    finally:
        solver.release()


def test_preview_shows_an_emitter_at_its_textured_radiance(ctx, gl_clean):
    """An emitter whose radiance comes from an emission texture (the add-on's Cycles
    evaluation gives every emitter one) shows emission x texture in the preview: a light of
    emission 1 and a texture of 6 seen face on is 6, not 1."""
    import dataclasses
    from native.preview import render_preview
    builder = SceneBuilder()
    builder.quad("floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], (0.5,) * 3)
    builder.quad("light", [(-.3, -.3, 1), (-.3, .3, 1), (.3, .3, 1), (.3, -.3, 1)], (0.0,) * 3,
                 (1.0,) * 3, two_sided=False)
    scene = builder.build()
    light = np.array(scene.object_names)[scene.object_index] == "light"
    scene = dataclasses.replace(
        scene, albedo_uv=np.full((len(scene.triangles), 3, 2), 0.5),
        emission_texture_index=np.where(light, 0, -1),
        emission_textures=[np.full((4, 4, 3), 6.0, dtype=np.float32)])
    solver = Solver(scene, Settings(texel_density=10, max_shots=20), ctx=ctx)
    try:
        solver.run()
        view = render_preview(solver, solver.result(), eye=(0.0, 0.0, 0.5),
                              target=(0.0, 0.0, 1.0), up=(0.0, 1.0, 0.0), fov=20.0,
                              size=(16, 16), supersample=1)
        np.testing.assert_allclose(view[8, 8], 6.0, rtol=1e-3)
    finally:
        solver.release()
