// Views used for visibility. A cube of six 90-degree faces around the eye in the shooter's
// frame (t, b, n): face 0 looks along +n, faces 1-4 along +-t and +-b with n up, face 5 along -n.
// The hemicube is faces 0-4. In orthographic mode (the sun) the window looking along +n is cut
// into u_sun_tiles x u_sun_tiles faces, face tx + u_sun_tiles ty its tile (tx, ty) from
// (-t, -b): a level's window spans hundreds of metres, and one face's texels let the sun
// past steps and ledges narrower than them.
// The hemisphere projections use two layers instead: 0 the hemisphere around +n, 1 around -n,
// each projected stereographically onto the unit disc.
#ifdef VIEW_PER_SHOOTER
// The batched receiver pass (receive_patch.frag) sets the eye and frame of each shooter of
// its batch in turn.
vec3 u_eye;
mat3 u_frame;
#else
uniform vec3 u_eye;
uniform mat3 u_frame;        // columns t, b, n
#endif
uniform int u_orthographic;
uniform float u_ortho_half;  // half width of the orthographic window
uniform float u_near;
uniform float u_far;
uniform int u_hemisphere;    // 1: the map holds stereographic hemispheres, not cube faces

uniform int u_sun_tiles;     // a side of the sun's window in tiles (preprocess.sun_tiles)

const vec3 FACE_FORWARD[6] = vec3[6](vec3(0, 0, 1), vec3(1, 0, 0), vec3(-1, 0, 0),
                                     vec3(0, 1, 0), vec3(0, -1, 0), vec3(0, 0, -1));
const vec3 FACE_RIGHT[6] = vec3[6](vec3(1, 0, 0), vec3(0, 1, 0), vec3(0, -1, 0),
                                   vec3(-1, 0, 0), vec3(1, 0, 0), vec3(1, 0, 0));
const vec3 FACE_UP[6] = vec3[6](vec3(0, 1, 0), vec3(0, 0, 1), vec3(0, 0, 1),
                                vec3(0, 0, 1), vec3(0, 0, 1), vec3(0, -1, 0));

vec3 to_local(vec3 world) { return transpose(u_frame) * (world - u_eye); }

// Half the width of one of the sun's tiles, and the middle of tile 'face' in the window.
float sun_tile_half() { return u_ortho_half / float(u_sun_tiles); }
vec2 sun_tile_middle(int face) {
    vec2 tile = vec2(face % u_sun_tiles, face / u_sun_tiles);
    return (2.0 * tile + 1.0) * sun_tile_half() - u_ortho_half;
}

// Clip-space position of a local point on a face.
vec4 face_clip(vec3 local, int face) {
    if (u_orthographic != 0) {
        vec2 xy = (local.xy - sun_tile_middle(face)) / sun_tile_half();
        return vec4(xy, 2.0 * (local.z - u_near) / (u_far - u_near) - 1.0, 1.0);
    }
    float x = dot(local, FACE_RIGHT[face]);
    float y = dot(local, FACE_UP[face]);
    float z = dot(local, FACE_FORWARD[face]);
    return vec4(x, y, (z * (u_far + u_near) - 2.0 * u_far * u_near) / (u_far - u_near), z);
}

// Distance stored in the visibility map: along the ray for the cube, along +n for the sun.
float view_distance(vec3 local) {
    return u_orthographic != 0 ? local.z : length(local);
}

// The sun's tile (tx, ty) that holds the window's point 'xy' (the nearest at its edges).
ivec2 sun_tile_of(vec2 xy) {
    return clamp(ivec2(floor((xy + u_ortho_half) / (2.0 * sun_tile_half()))), ivec2(0),
                 ivec2(u_sun_tiles - 1));
}

int face_of(vec3 local) {
    if (u_orthographic != 0) {
        ivec2 tile = sun_tile_of(local.xy);
        return tile.x + u_sun_tiles * tile.y;
    }
    vec3 a = abs(local);
    if (a.z >= a.x && a.z >= a.y) return local.z >= 0.0 ? 0 : 5;
    if (a.x >= a.y) return local.x >= 0.0 ? 1 : 2;
    return local.y >= 0.0 ? 3 : 4;
}

// Coordinates in the frame of hemisphere 'side': the back one is the front one turned half a
// turn about t, so both stay right-handed.
vec3 hemisphere_local(vec3 local, int side) {
    return side == 0 ? local : vec3(local.x, -local.y, -local.z);
}

// Stereographic projection from the far pole: the zenith maps to the centre of the unit disc,
// the horizon to its rim; directions below the horizon land outside.
vec2 stereographic(vec3 v) {
    float r = length(v);
    return v.xy / max(r + v.z, 1e-6 * r);
}

// The direction a point of the unit disc comes from: the inverse of stereographic().
vec3 inverse_stereographic(vec2 p) {
    float rho2 = dot(p, p);
    return vec3(2.0 * p, 1.0 - rho2) / (1.0 + rho2);
}
