#version 410
// Radiance seen by the camera: the baked reflected radiance plus the surface's own emission.
uniform sampler2DArray u_lightmaps;
in vec3 v_lightmap;
flat in vec4 v_emission;
layout(location = 0) out vec4 out_color;
void main() {
    vec3 radiance = v_lightmap.z >= 0.0 ? texture(u_lightmaps, v_lightmap).rgb : vec3(0.0);
    if (gl_FrontFacing || v_emission.a > 0.0) radiance += v_emission.rgb;
    out_color = vec4(radiance, 1.0);
}
