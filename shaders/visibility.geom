#version 410
// All faces of the visibility cube in one pass, each routed to its layer: one invocation per
// triangle that projects it once and emits it to the faces it reaches. A front-only shooter
// clips geometry behind its plane. (llvmpipe runs geometry shaders on the calling thread,
// before its threaded rasteriser: six invocations per triangle, one per face, made this pass
// most of a shot on scenes of many triangles; visibility_face.vert draws face by face.) The
// corners go out in their order: the fragment shader tells the side facing the eye by it.
layout(triangles) in;
// MOST_VERTICES, defined where the program is made (preprocess.create_programs): a triangle
// for each of the cube's six faces, or of a sun's tiles where they are more. A larger
// output costs a GPU's geometry stage.
layout(triangle_strip, max_vertices = MOST_VERTICES) out;

uniform int u_face_count;
uniform int u_clip_below;
uniform int u_first_layer;   // the shooter's map in a batch's (visibility.render)

in vec3 v_world[];
in float v_surface[];
out vec3 g_local;
flat out float g_surface;

#include "projection.glsl"

// Whether the triangle lies wholly outside one plane of a face's view volume, where clipping
// would leave nothing of it.
bool outside(vec4 clip[3]) {
    for (int axis = 0; axis < 3; ++axis) {
        if (clip[0][axis] > clip[0].w && clip[1][axis] > clip[1].w && clip[2][axis] > clip[2].w)
            return true;
        if (clip[0][axis] < -clip[0].w && clip[1][axis] < -clip[1].w
            && clip[2][axis] < -clip[2].w) return true;
    }
    return false;
}

void main() {
    vec3 local[3] = vec3[3](to_local(v_world[0]), to_local(v_world[1]), to_local(v_world[2]));
    if (u_clip_below != 0 && local[0].z < 0.0 && local[1].z < 0.0 && local[2].z < 0.0) return;
    // The sun's tiles under the triangle's box in the window (a margin wide), not all of
    // them: a level's window has up to 16, and each costs a GPU's geometry stage its loop.
    int faces = u_face_count, first = 0, columns = u_face_count;
    if (u_orthographic != 0) {
        vec2 margin = vec2(1e-3 * sun_tile_half());
        ivec2 low = sun_tile_of(min(min(local[0].xy, local[1].xy), local[2].xy) - margin);
        ivec2 high = sun_tile_of(max(max(local[0].xy, local[1].xy), local[2].xy) + margin);
        first = low.x + u_sun_tiles * low.y;
        columns = high.x - low.x + 1;
        faces = columns * (high.y - low.y + 1);
    }
    for (int k = 0; k < faces; ++k) {
        int face = first + k % columns + u_sun_tiles * (k / columns);
        vec4 clip[3];
        for (int i = 0; i < 3; ++i) clip[i] = face_clip(local[i], face);
        if (outside(clip)) continue;
        for (int i = 0; i < 3; ++i) {
            g_local = local[i];
            g_surface = v_surface[0];
            gl_Position = clip[i];
            gl_ClipDistance[0] = u_clip_below != 0 ? local[i].z : 1.0;
            gl_Layer = u_first_layer + face;
            EmitVertex();
        }
        EndPrimitive();
    }
}
