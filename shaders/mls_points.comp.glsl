// Evaluates f (and optionally M) at an arbitrary list of points, or at the vertices of a
// regular mesh when MLS_MESH is 1 (vertex (i, j) at min(origin + (i, j) * step, last)).
// A mesh too big for one buffer is evaluated in bands of rows: u_mesh_first_row is the mesh
// row of the band's first row (0 for a whole mesh), so that vertices shared by two bands are
// computed from the same integers and the bands meet without cracks.
layout(local_size_x = 64) in;

#if MLS_MESH
uniform vec2 u_mesh_origin;   // scaled
uniform vec2 u_mesh_step;     // scaled
uniform vec2 u_mesh_last;     // scaled; the last row/column lands exactly on it
uniform ivec2 u_mesh_dims;    // vertices per row, rows (of this band)
uniform int u_mesh_first_row; // mesh row of this band's first row
#else
layout(std430, binding = 1) readonly buffer MLSPoints {
    vec2 mls_points[];
};
#endif
uniform int u_count;     // points (or vertices) in all
uniform int u_offset;    // first index of this dispatch (dispatches are capped in size)

layout(std430, binding = 2) writeonly buffer MLSOutF {
    vec2 mls_out_f[];
};
#if MLS_WRITE_MATRIX
layout(std430, binding = 3) writeonly buffer MLSOutM {
    vec4 mls_out_m[];
};
#endif

void main() {
    int i = u_offset + int(gl_GlobalInvocationID.x);
    bool live = i < u_count;
#if MLS_MESH
    ivec2 ij = ivec2(i % u_mesh_dims.x, i / u_mesh_dims.x);
    ij.y += u_mesh_first_row;
    vec2 v = min(u_mesh_origin + vec2(ij) * u_mesh_step, u_mesh_last);
#else
    vec2 v = live ? mls_points[i] : vec2(0.0);
#endif
    if (!live) {
        return;
    }
    MLSResult r = mls_eval(v);
    mls_out_f[i] = r.f;
#if MLS_WRITE_MATRIX
    mls_out_m[i] = r.M;
#endif
}
