#version 410
// Non-linear hemisphere projection after Gascuel et al. 2008, first step: a bounding primitive
// around the triangle's true (curved) stereographic image. The triangle is clipped to the
// hemisphere; each edge of what is left is a great-circle arc, sampled along the arc to bound
// it, and the bounding box is emitted with the triangle's corners for the fragment test.
layout(triangles) in;  // one invocation draws every layer (see visibility.geom)
layout(triangle_strip, max_vertices = 8) out;

uniform int u_face_count;    // hemispheres drawn: 1 (front) or 2 (front and back)
uniform float u_resolution;  // map side in texels

in vec3 v_world[];
in float v_surface[];
flat out vec3 g_corner[3];   // the triangle in this hemisphere's frame
flat out float g_surface;
flat out int g_faces_away;

#include "projection.glsl"
#include "visibility_store.glsl"

const int ARC_SAMPLES = 12;

// Grows 'box' (min xy, max xy) by the stereographic image of the arc from a to b (unit vectors).
void bound_arc(inout vec4 box, vec3 a, vec3 b) {
    float angle = acos(clamp(dot(a, b), -1.0, 1.0));
    float s = sin(angle);
    for (int k = 0; k <= ARC_SAMPLES; ++k) {
        float t = float(k) / float(ARC_SAMPLES);
        vec3 d = s > 1e-5 ? (sin((1.0 - t) * angle) * a + sin(t * angle) * b) / s
                          : normalize(mix(a, b, t));
        vec2 p = stereographic(d);
        box = vec4(min(box.xy, p), max(box.zw, p));
    }
}

// The triangle on hemisphere 'side'.
void draw(int side) {
    bool away = faces_away_from_eye(to_local(v_world[0]), to_local(v_world[1]),
                                    to_local(v_world[2]));
    vec3 c[3];
    for (int i = 0; i < 3; ++i) c[i] = hemisphere_local(to_local(v_world[i]), side);
    vec3 n = cross(c[1] - c[0], c[2] - c[0]);
    float size = max(length(c[0]), max(length(c[1]), length(c[2])));
    // A triangle whose plane passes through the eye covers no solid angle.
    if (abs(dot(n, c[0])) <= 1e-6 * length(n) * size) return;

    vec3 polygon[4];
    int count = 0;
    for (int i = 0; i < 3; ++i) {
        vec3 a = c[i], b = c[(i + 1) % 3];
        if (a.z >= 0.0) polygon[count++] = a;
        if ((a.z >= 0.0) != (b.z >= 0.0)) polygon[count++] = a + (b - a) * (a.z / (a.z - b.z));
    }
    if (count < 3) return;
    vec4 box = vec4(1e9, 1e9, -1e9, -1e9);
    for (int i = 0; i < count; ++i) {
        vec3 a = polygon[i], b = polygon[(i + 1) % count];
        if (length(a) == 0.0 || length(b) == 0.0) return;
        bound_arc(box, normalize(a), normalize(b));
    }
    // Sampled arcs can bulge a little past their samples; texel centres need a margin too.
    float margin = 0.02 * max(box.z - box.x, box.w - box.y) + 4.0 / u_resolution;
    box = clamp(box + vec4(-margin, -margin, margin, margin), -1.0, 1.0);

    vec2 corners[4] = vec2[4](box.xy, box.zy, box.xw, box.zw);
    for (int i = 0; i < 4; ++i) {
        g_corner = c;
        g_surface = v_surface[0];
        g_faces_away = int(away);
        gl_Position = vec4(corners[i], 0.0, 1.0);
        gl_Layer = side;
        EmitVertex();
    }
    EndPrimitive();
}

void main() {
    for (int side = 0; side < u_face_count; ++side) draw(side);
}
