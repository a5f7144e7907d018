// Evaluates f (and optionally M) at a list of points, or (MLS_LATTICE) at the points of a
// lattice (mls/lattice.glsl) band by band: the band's first row is lattice row u_first_row,
// and its points are written from index 0 (u_count of them, whole rows). For a list of points
// the output is the displacement f(v) - v (scaled), for a lattice f(v) itself. A batch's
// (MLS_BATCH) list: image b's points and outputs from b * u_batch_stride on.
layout(local_size_x = LOCAL_SIZE) in;

#ifndef MLS_POINTS_PER_INVOCATION
#define MLS_POINTS_PER_INVOCATION 1
#endif

#include "mls/batch.glsl"
#if MLS_BATCH
int mls_batch_out;   // where the work group's image's lattice goes in the output
#else
const int mls_batch_out = 0;
#endif

#include "mls/visit.glsl"

#if MLS_LATTICE
#include "mls/lattice.glsl"
uniform int u_first_row;
#elif MLS_BATCH  // the image table takes BIND_POINTS
layout(std430, binding = BIND_BATCH_POINTS) readonly buffer MLSPoints {
    vec2 mls_points[];
};
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

// f (and M) of item i stored: a list's displacement f(v) - v (the caller adds v in float64),
// a lattice's f(v) itself.
void mls_store(int i, MLSResult r) {
#if MLS_LATTICE
    mls_out_f[mls_batch_out + i] = r.f;
#else
    mls_out_f[u_out_first + mls_batch_out + i] = r.d;
#endif
#if MLS_WRITE_MATRIX
    mls_out_m[i] = r.M;
#endif
}

// r, or NaN where a CPU renderer's cap on loop iterations cut a walk short
// (common/loops.glsl; glmls.engine.loops keeps the handles within it, this marks what
// escapes it): f then left handles out, and no pass takes it for f.
MLSResult mls_checked(MLSResult r, bool whole) {
    vec2 nan = vec2(uintBitsToFloat(0x7fc00000u));
    r.f = whole ? r.f : nan;
    r.d = whole ? r.d : nan;
    return r;
}

vec2 mls_item_point(int i) {
#if MLS_LATTICE
    int nx = u_lattice_dims.x;
    return mls_lattice_point(ivec2(i % nx, i / nx + u_first_row));
#else
    return mls_points[mls_batch_out + i];
#endif
}

void main() {
    // MLS_POINTS_PER_INVOCATION (1 or 2) consecutive items per invocation, from u_offset.
    // No early return for the items past the end: they evaluate the last point and store
    // nothing. llvmpipe loads a value at a uniform index once for all lanes only where no
    // lane can be inactive (outside any branch, and after no return); behind a return every
    // handle read is a load per lane (W1's grid-4 pass took 1.4x as long).
#if MLS_BATCH
    mls_batch_begin(int(gl_WorkGroupID.y));
    mls_batch_out = mls_batch_image_index * u_batch_stride;
#endif
    int first = u_offset + MLS_POINTS_PER_INVOCATION * int(gl_GlobalInvocationID.x);
    int last = max(u_count - 1, 0);
#if MLS_POINTS_PER_INVOCATION == 2
    MLSResult r0, r1;
    mls_eval_pair(mls_item_point(min(first, last)), mls_item_point(min(first + 1, last)), r0, r1);
    bool whole = mls_loops_whole();
    r0 = mls_checked(r0, whole);
    r1 = mls_checked(r1, whole);
    if (first < u_count) {
        mls_store(first, r0);
    }
    if (first + 1 < u_count) {
        mls_store(first + 1, r1);
    }
#else
    MLSResult r = mls_eval(mls_item_point(min(first, last)));
    r = mls_checked(r, mls_loops_whole());
    if (first < u_count) {
        mls_store(first, r);
    }
#endif
}
