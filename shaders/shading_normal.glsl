// The interpolated shading normal at barycentrics w, or the face normal where the corners'
// normals cancel or point behind the face.
vec3 shading_normal(vec3 w) {
    vec3 normal = w.x * g_normal[0] + w.y * g_normal[1] + w.z * g_normal[2];
    float len = length(normal);
    return (len > 1e-12 && dot(normal, g_face_normal) > 0.0) ? normal / len : g_face_normal;
}
