#version 410
// What a receiver pass gathered, added to the page's maps (receivers.update): the
// irradiance, the radiance the texel reflects and must shoot later, and where glossy layers
// leave in lobes the directions it came in; every texel's light scaled down alike where the
// pass's texels took more than its limits allow. A form factor at a coarse texel's sample
// point, times the texel's area, can exceed the share of the shot the texel can take, and
// a level's unshot power grew without end. The received light may exceed what was sent by
// a little (receivers.RECEIVED_SURPLUS: form factors err both ways and cancel over shots in
// a closed room; held to what was sent, a furnace of albedo 0.9 came out 4 % dark); the
// unshot power it adds is held to what was sent times the largest reflectance, less what
// the shot's thin gaps left (receivers.unshot_limit).
#include "texel_maps.glsl"
uniform sampler2D u_gathered;
uniform sampler2D u_position;
uniform sampler2D u_material;
// 1 x 1 each (W, RGB): the power the pass's texels received, and the unshot power it would
// add (gathered_power.vert).
uniform sampler2D u_received;
uniform sampler2D u_reflected;
uniform vec3 u_received_limit;   // W, RGB
uniform vec3 u_unshot_limit;
uniform sampler2D u_gathered_incoming;   // read where the scene keeps incoming directions
layout(location = 0) out vec4 out_irradiance;
layout(location = 1) out vec4 out_unshot;
#if GLOSSY_LOBES
layout(location = 2) out vec4 out_incoming;
#endif

const float PI = 3.14159265358979;

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    vec4 material = texelFetch(u_material, texel, 0);
    // A texel that does not receive holds what an earlier pass left (gathered_power.vert).
    if (!receives(texelFetch(u_position, texel, 0), material)) discard;
    vec3 irradiance = texelFetch(u_gathered, texel, 0).rgb;
    float gathered = irradiance.r + irradiance.g + irradiance.b;
    if (gathered <= 0.0) discard;
    vec3 received = texelFetch(u_received, ivec2(0), 0).rgb;
    vec3 reflected = texelFetch(u_reflected, ivec2(0), 0).rgb;
    vec3 scale = min(vec3(1.0), min(u_received_limit / max(received, vec3(1e-30)),
                                    u_unshot_limit / max(reflected, vec3(1e-30))));
    vec3 scaled = irradiance * scale;
    out_irradiance = vec4(scaled, 0.0);
    out_unshot = vec4(material.rgb * scaled / PI, 0.0);
#if GLOSSY_LOBES
    // The directions weighted by the irradiance each brought: scaled as its sum.
    out_incoming = texelFetch(u_gathered_incoming, texel, 0)
        * ((scaled.r + scaled.g + scaled.b) / gathered);
#endif
}
