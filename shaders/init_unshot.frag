#version 410
// Initial unshot radiance: the emission of every emitting texel, and a flag for the back face
// of emitters that emit from both faces (shot once with the emission radiance).
uniform sampler2D u_emission;
layout(location = 0) out vec4 out_unshot;
void main() {
    out_unshot = texelFetch(u_emission, ivec2(gl_FragCoord.xy), 0);
}
