// Views used for visibility. A cube of six 90-degree faces around the eye in the shooter's
// frame (t, b, n): face 0 looks along +n, faces 1-4 along +-t and +-b with n up, face 5 along -n.
// The hemicube is faces 0-4. In orthographic mode (the sun) there is one face looking along +n.
uniform vec3 u_eye;
uniform mat3 u_frame;        // columns t, b, n
uniform int u_orthographic;
uniform float u_ortho_half;  // half width of the orthographic window
uniform float u_near;
uniform float u_far;

const vec3 FACE_FORWARD[6] = vec3[6](vec3(0, 0, 1), vec3(1, 0, 0), vec3(-1, 0, 0),
                                     vec3(0, 1, 0), vec3(0, -1, 0), vec3(0, 0, -1));
const vec3 FACE_RIGHT[6] = vec3[6](vec3(1, 0, 0), vec3(0, 1, 0), vec3(0, -1, 0),
                                   vec3(-1, 0, 0), vec3(1, 0, 0), vec3(1, 0, 0));
const vec3 FACE_UP[6] = vec3[6](vec3(0, 1, 0), vec3(0, 0, 1), vec3(0, 0, 1),
                                vec3(0, 0, 1), vec3(0, 0, 1), vec3(0, -1, 0));

vec3 to_local(vec3 world) { return transpose(u_frame) * (world - u_eye); }

// Clip-space position of a local point on a face.
vec4 face_clip(vec3 local, int face) {
    float x = dot(local, FACE_RIGHT[face]);
    float y = dot(local, FACE_UP[face]);
    float z = dot(local, FACE_FORWARD[face]);
    if (u_orthographic != 0) {
        return vec4(x / u_ortho_half, y / u_ortho_half, 2.0 * (z - u_near) / (u_far - u_near) - 1.0, 1.0);
    }
    return vec4(x, y, (z * (u_far + u_near) - 2.0 * u_far * u_near) / (u_far - u_near), z);
}

// Distance stored in the visibility map: along the ray for the cube, along +n for the sun.
float view_distance(vec3 local) {
    return u_orthographic != 0 ? local.z : length(local);
}

int face_of(vec3 local) {
    if (u_orthographic != 0) return 0;
    vec3 a = abs(local);
    if (a.z >= a.x && a.z >= a.y) return local.z >= 0.0 ? 0 : 5;
    if (a.x >= a.y) return local.x >= 0.0 ? 1 : 2;
    return local.y >= 0.0 ? 3 : 4;
}
