"""A camera view of the scene lit by its lightmaps (bilinear lookups, as a game engine or
Blender would show them): the demo's preview and a visual check for seams."""
import math

import moderngl
import numpy as np

from .gpu import GLObjects, using


def look_at(eye, target, up, fov_degrees, aspect, near=0.01, far=100.0):
    """View-projection matrix (column-major for GLSL) of a perspective camera."""
    eye, target, up = (np.asarray(v, dtype=np.float64) for v in (eye, target, up))
    forward = target - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, forward)
    view = np.eye(4)
    view[0, :3], view[1, :3], view[2, :3] = right, true_up, -forward
    view[:3, 3] = -view[:3, :3] @ eye
    f = 1.0 / math.tan(math.radians(fov_degrees) / 2)
    projection = np.zeros((4, 4))
    projection[0, 0], projection[1, 1] = f / aspect, f
    projection[2, 2] = (far + near) / (near - far)
    projection[2, 3] = 2 * far * near / (near - far)
    projection[3, 2] = -1.0
    return projection @ view


def scene_emission(scene):
    """Each triangle's emitted radiance (T, 3): its emission, times its emission texture at
    the triangle's centre where it has one (a preview's flat shade of a textured emitter)."""
    emission = np.array(scene.emission, dtype=np.float64)
    index = scene.emission_texture_index
    if index is None or not scene.emission_textures:
        return emission
    centres = scene.albedo_uv.mean(axis=1)
    for page, texture in enumerate(scene.emission_textures):
        mine = index == page
        height, width = texture.shape[:2]
        column = np.clip((centres[mine, 0] * width).astype(np.int64), 0, width - 1)
        row = np.clip((centres[mine, 1] * height).astype(np.int64), 0, height - 1)
        emission[mine] *= texture[row, column, :3]
    return emission


def render_preview(solver, lightmaps, eye, target, up=(0.0, 1.0, 0.0), fov=40.0,
                   size=(512, 512), supersample=2):
    """Linear radiance (height, width, 3), top row first, of the scene seen from ``eye``."""
    scene, atlas = solver.scene, solver.atlas
    count = len(scene.triangles)
    lightmap = np.full((count, 3, 3), -1.0)
    uv = atlas.uv()
    lightmap[atlas.triangles, :, :2] = uv
    lightmap[atlas.triangles, :, 2] = atlas.page[:, None]
    lightmap[~scene.receive, :, 2] = -1.0
    emission = np.concatenate([scene_emission(scene), scene.emission_two_sided[:, None]], axis=1)
    vertices = np.concatenate([scene.vertices[scene.triangles], lightmap,
                               np.repeat(emission[:, None, :], 3, axis=1)], axis=2)
    # A triangle with a mirrored copy (Scene.with_back_faces) and the copy are each drawn from
    # the front only, the copy showing the back; the others from both sides. Culled ones first.
    culled = np.zeros(count, bool)
    if scene.back_of is not None:
        copies = scene.back_of >= 0
        culled[copies] = True
        culled[scene.back_of[copies]] = True
    vertices = np.concatenate([vertices[culled], vertices[~culled]])
    culled_count = int(culled.sum())
    width, height = size[0] * supersample, size[1] * supersample
    ctx = solver.ctx
    with using(ctx):
        gl = GLObjects(ctx)
        try:
            pages = np.stack([np.asarray(page, dtype=np.float32) for page in lightmaps])
            texture = gl.keep(ctx.texture_array((atlas.width, atlas.height, len(pages)), 4,
                                                data=pages.tobytes(), dtype="f4"))
            texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            texture.repeat_x = texture.repeat_y = False
            program = gl.program("preview.vert", "preview.frag")
            vbo = gl.buffer(vertices.astype("f4").tobytes())
            vao = gl.vertex_array(program, [(vbo, "3f 3f 4f", "in_position", "in_lightmap",
                                             "in_emission")])
            color = gl.texture((width, height), 4)
            depth = gl.keep(ctx.depth_renderbuffer((width, height)))
            framebuffer = gl.framebuffer([color], depth)
            matrix = look_at(eye, target, up, fov, width / height)
            program["u_view_projection"].write(matrix.T.astype("f4").tobytes())
            program["u_lightmaps"].value = 0
            framebuffer.use()
            framebuffer.clear(0.0, 0.0, 0.0, 1.0, depth=1.0)
            texture.use(location=0)
            ctx.enable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
            vao.render(moderngl.TRIANGLES, vertices=3 * culled_count)
            ctx.disable(moderngl.CULL_FACE)
            vao.render(moderngl.TRIANGLES, vertices=3 * (count - culled_count),
                       first=3 * culled_count)
            ctx.disable(moderngl.DEPTH_TEST)
            image = np.frombuffer(color.read(), dtype="f4").reshape(height, width, 4)[..., :3]
        finally:
            gl.release()
    image = image.reshape(size[1], supersample, size[0], supersample, 3).mean(axis=(1, 3))
    return np.flipud(image).copy()
