// Evaluates f (and optionally M) at a list of points, or (MLS_LATTICE) at the points of a
// lattice (mls/lattice.glsl) band by band: the band's first row is lattice row u_first_row,
// and its points are written from index 0 (u_count of them, whole rows). For a list of points
// the output is the displacement f(v) - v (scaled), for a lattice f(v) itself.
layout(local_size_x = LOCAL_SIZE) in;

#include "mls/visit.glsl"

#if MLS_LATTICE
#include "mls/lattice.glsl"
uniform int u_first_row;
#else
layout(std430, binding = BIND_POINTS) readonly buffer MLSPoints {
    vec2 mls_points[];
};
#endif
uniform int u_count;     // points (or lattice points of the band) in all
uniform int u_offset;    // first index of this dispatch (dispatches are capped in size)
uniform int u_out_first; // a list's f: where point 0's goes in the output (a kept store's end)

layout(std430, binding = BIND_DEFORMED) writeonly buffer MLSOutF {
    vec2 mls_out_f[];
};
#if MLS_WRITE_MATRIX
layout(std430, binding = BIND_MATRICES) writeonly buffer MLSOutM {
    vec4 mls_out_m[];
};
#endif

void main() {
    int i = u_offset + int(gl_GlobalInvocationID.x);
    if (i >= u_count) {
        return;
    }
#if MLS_LATTICE
    int nx = u_lattice_dims.x;
    vec2 v = mls_lattice_point(ivec2(i % nx, i / nx + u_first_row));
#else
    vec2 v = mls_points[i];
#endif
    MLSResult r = mls_eval(v);
#if MLS_LATTICE
    mls_out_f[i] = r.f;
#else
    mls_out_f[u_out_first + i] = r.d;   // f(v) - v: the caller adds v in float64
#endif
#if MLS_WRITE_MATRIX
    mls_out_m[i] = r.M;
#endif
}
