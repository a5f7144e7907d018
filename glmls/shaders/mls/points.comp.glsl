// Evaluates f (and optionally M) at a list of points, or (MLS_LATTICE) at the points of a
// lattice (mls/lattice.glsl) band by band: the band's first row is lattice row u_first_row,
// and its points are written from index 0 (u_count of them, whole rows). For a list of points
// the output is the displacement f(v) - v (scaled), for a lattice f(v) itself.
layout(local_size_x = LOCAL_SIZE) in;

#ifndef MLS_POINTS_PER_INVOCATION
#define MLS_POINTS_PER_INVOCATION 1
#endif

#ifndef MLS_BATCH
#define MLS_BATCH 0   // 1: a batch's lattice pass (mls/points.comp.glsl)
#endif
#if MLS_BATCH
// A batch's lattices in one dispatch (glmls.engine.batched, with MLS_LATTICE): work group
// row gl_WorkGroupID.y evaluates image b's lattice, whose f goes to the output from its
// table row's vec2 index. Image b's handles are rows first .. first + count - 1 of one handle
// buffer, and the values that a single image's pass takes from uniforms (mls/weighting.glsl,
// mls/lattice.glsl) are its row of the image table, read once for the work group: the same
// arithmetic as a pass per image.
struct MLSBatchImage {
    vec4 lattice;    // u_lattice_origin, u_lattice_last
    vec4 weights;    // u_lattice_step (both axes), u_log2_s, u_radius, u_hit2
    ivec4 handles;   // first, count, u_snap, the output's first vec2
};
layout(std430, binding = BIND_POINTS) readonly buffer MLSBatchImages {
    MLSBatchImage mls_batch_image[];
};
layout(std430, binding = BIND_HANDLES) readonly buffer MLSHandles {
    vec4 mls_handles[];
};
float u_log2_s;
float u_radius;
float u_hit2;
bool u_snap;
vec2 u_lattice_origin;
vec2 u_lattice_step;
vec2 u_lattice_last;
int mls_batch_first;
int mls_batch_count;
int mls_batch_out;

int mls_handle_count() {
    return mls_batch_count;
}

vec4 mls_handle(int i) {
    return mls_handles[mls_batch_first + i];
}

void mls_batch_begin() {
    MLSBatchImage image = mls_batch_image[gl_WorkGroupID.y];
    u_lattice_origin = image.lattice.xy;
    u_lattice_last = image.lattice.zw;
    u_lattice_step = image.weights.xx;
    u_log2_s = image.weights.y;
    u_radius = image.weights.z;
    u_hit2 = image.weights.w;
    mls_batch_first = image.handles.x;
    mls_batch_count = image.handles.y;
    u_snap = image.handles.z != 0;
    mls_batch_out = image.handles.w;
}
#else
const int mls_batch_out = 0;

void mls_batch_begin() {
}
#endif

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

// f (and M) of item i stored: a list's displacement f(v) - v (the caller adds v in float64),
// a lattice's f(v) itself.
void mls_store(int i, MLSResult r) {
#if MLS_LATTICE
    mls_out_f[mls_batch_out + i] = r.f;
#else
    mls_out_f[u_out_first + i] = r.d;
#endif
#if MLS_WRITE_MATRIX
    mls_out_m[i] = r.M;
#endif
}

vec2 mls_item_point(int i) {
#if MLS_LATTICE
    int nx = u_lattice_dims.x;
    return mls_lattice_point(ivec2(i % nx, i / nx + u_first_row));
#else
    return mls_points[i];
#endif
}

void main() {
    // MLS_POINTS_PER_INVOCATION (1 or 2) consecutive items per invocation, from u_offset.
    // No early return for the items past the end: they evaluate the last point and store
    // nothing. llvmpipe loads a value at a uniform index once for all lanes only where no
    // lane can be inactive (outside any branch, and after no return); behind a return every
    // handle read is a load per lane (W1's grid-4 pass took 1.4x as long).
    mls_batch_begin();
    int first = u_offset + MLS_POINTS_PER_INVOCATION * int(gl_GlobalInvocationID.x);
    int last = max(u_count - 1, 0);
#if MLS_POINTS_PER_INVOCATION == 2
    MLSResult r0, r1;
    mls_eval_pair(mls_item_point(min(first, last)), mls_item_point(min(first + 1, last)), r0, r1);
    if (first < u_count) {
        mls_store(first, r0);
    }
    if (first + 1 < u_count) {
        mls_store(first + 1, r1);
    }
#else
    MLSResult r = mls_eval(mls_item_point(min(first, last)));
    if (first < u_count) {
        mls_store(first, r);
    }
#endif
}
