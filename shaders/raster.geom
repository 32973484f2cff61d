#version 410
// Conservative rasterization in lightmap space: the triangle's bounding box, grown to whole
// texels, is drawn, so every texel the triangle touches gets a fragment however thin or sharp
// the triangle (pushing edges out, as in GPU Gems 2, fails at sharp corners); the fragment
// shader clips the texel square against the exact triangle and discards texels it misses.
layout(triangles) in;
layout(triangle_strip, max_vertices = 4) out;

uniform vec2 u_atlas_size;   // page size in texels

in VertexData {
    vec2 texel;
    vec3 position;
    vec3 normal;
    vec2 tex_uv;
    vec3 albedo;
    vec3 reflectance;
    vec3 emission;
    float receive;
    float roughness;
} v[];

flat out vec2 g_texel[3];
flat out vec3 g_position[3];
flat out vec3 g_normal[3];
flat out vec2 g_tex_uv[3];
flat out vec3 g_albedo;
flat out vec3 g_reflectance;
flat out vec3 g_emission;
flat out float g_receive;
flat out float g_roughness;
flat out vec3 g_face_normal;
flat out float g_texel_size;      // world length of one texel edge
flat out float g_area_per_texel;  // world area of one texel square on this triangle

#include "plane2d.glsl"

void main() {
    vec2 t0 = v[0].texel, t1 = v[1].texel, t2 = v[2].texel;
    float uv_area2 = cross2(t1 - t0, t2 - t0);
    vec3 e1 = v[1].position - v[0].position;
    vec3 e2 = v[2].position - v[0].position;
    vec3 n = cross(e1, e2);
    float world_area2 = length(n);
    if (abs(uv_area2) < 1e-10 || world_area2 <= 0.0) return;

    for (int i = 0; i < 3; ++i) {
        g_texel[i] = v[i].texel;
        g_position[i] = v[i].position;
        g_normal[i] = v[i].normal;
        g_tex_uv[i] = v[i].tex_uv;
    }
    g_face_normal = n / world_area2;
    g_area_per_texel = world_area2 / abs(uv_area2);
    g_texel_size = sqrt(g_area_per_texel);

    vec2 lo = floor(min(min(t0, t1), t2));
    vec2 hi = floor(max(max(t0, t1), t2)) + 1.0;
    g_albedo = v[0].albedo;
    g_reflectance = v[0].reflectance;
    g_emission = v[0].emission;
    g_receive = v[0].receive;
    g_roughness = v[0].roughness;
    vec2 corners[4] = vec2[4](lo, vec2(hi.x, lo.y), vec2(lo.x, hi.y), hi);
    for (int i = 0; i < 4; ++i) {
        gl_Position = vec4(corners[i] / u_atlas_size * 2.0 - 1.0, 0.0, 1.0);
        EmitVertex();
    }
    EndPrimitive();
}
