#version 410
// How many texels of each sun's window something was drawn into (visibility.covered_shares):
// the i-th sun of a batch counts the u_faces layers of its tiles (from layer u_faces i,
// visibility.render_batch) into pixel i of a row, a band of u_rows rows per point, the
// bands summed by blending (llvmpipe ends a loop after 65535 turns, nested ones counted
// together). Read back as a handful of numbers, not the maps.
uniform sampler2DArray u_visibility;
uniform float u_drawn;      // a map texel under this distance holds something
uniform int u_pixels;       // the row's width
uniform int u_rows;         // the rows each point counts
uniform int u_faces;        // the layers of each sun's map
flat out float v_covered;

void main() {
    ivec2 size = textureSize(u_visibility, 0).xy;
    int bands = (size.y + u_rows - 1) / u_rows;
    int sun = gl_VertexID / bands;
    int first = (gl_VertexID % bands) * u_rows;
    float covered = 0.0;   // exact: a map has far fewer than 2^24 texels
    for (int face = 0; face < u_faces; ++face) {
        for (int y = first; y < min(first + u_rows, size.y); ++y) {
            for (int x = 0; x < size.x; ++x) {
                if (texelFetch(u_visibility, ivec3(x, y, u_faces * sun + face), 0).r < u_drawn)
                    covered += 1.0;
            }
        }
    }
    v_covered = covered;
    gl_Position = vec4((float(sun) + 0.5) / float(u_pixels) * 2.0 - 1.0, 0.0, 0.0, 1.0);
}
