#version 410
// What a receiver pass gathered, added to the page's maps (receivers.update): the
// irradiance, the radiance the texel reflects and must shoot later, and where glossy layers
// leave in lobes the directions it came in. Where the pass's light would add more unshot
// power than its shooters sent (u_reflected over u_shot_power), every texel takes its light
// scaled down by the same factor, so that no pass makes light: a form factor at a coarse
// texel's sample point, times the texel's area, can exceed the share of the shot the texel
// can take, and a level's unshot power then grew without end. Form factors err both ways
// and cancel over shots in a closed room: the light received alone is not held to what was
// sent (that darkened a furnace of albedo 0.9 by 4 %).
uniform sampler2D u_gathered;
uniform sampler2D u_material;
uniform sampler2D u_reflected;   // 1 x 1: the unshot power the pass's light would add
                                 // (W, RGB)
uniform vec3 u_shot_power;       // what its shooters sent (W, RGB)
uniform sampler2D u_gathered_incoming;   // read where the scene keeps incoming directions
layout(location = 0) out vec4 out_irradiance;
layout(location = 1) out vec4 out_unshot;
#if GLOSSY_LOBES
layout(location = 2) out vec4 out_incoming;
#endif

const float PI = 3.14159265358979;

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    vec3 irradiance = texelFetch(u_gathered, texel, 0).rgb;
    float gathered = irradiance.r + irradiance.g + irradiance.b;
    if (gathered <= 0.0) discard;
    vec3 reflected = texelFetch(u_reflected, ivec2(0), 0).rgb;
    vec3 scale = min(vec3(1.0), u_shot_power / max(reflected, vec3(1e-30)));
    vec3 scaled = irradiance * scale;
    out_irradiance = vec4(scaled, 0.0);
    out_unshot = vec4(texelFetch(u_material, texel, 0).rgb * scaled / PI, 0.0);
#if GLOSSY_LOBES
    // The directions weighted by the irradiance each brought: scaled as its sum.
    out_incoming = texelFetch(u_gathered_incoming, texel, 0)
        * ((scaled.r + scaled.g + scaled.b) / gathered);
#endif
}
