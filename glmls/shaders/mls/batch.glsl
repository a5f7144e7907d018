// A batch's MLS (glmls.engine.batched), MLS_BATCH 1: the passes over many images in one
// dispatch, each work group on one image. Image b's handles are rows first .. first +
// count - 1 of one handle buffer; the values that a single image's pass takes from uniforms
// (mls/weighting.glsl, mls/lattice.glsl, warp/frame.glsl's scaling) are its row of an image
// table, read once per work group by mls_batch_begin: the same arithmetic as a pass per
// image. Include before mls/visit.glsl.
#ifndef MLS_BATCH
#define MLS_BATCH 0
#endif
#if MLS_BATCH
#ifndef MLS_UBO_CAPACITY
#define MLS_UBO_CAPACITY 0   // handle rows of the uniform block; 0: a storage buffer
#endif
struct MLSBatchImage {
    vec4 lattice;    // u_lattice_origin, u_lattice_last
    vec4 weights;    // u_lattice_step (both axes), u_log2_s, u_radius, u_hit2
    vec4 frame;      // u_center, u_scale, unused
    ivec4 handles;   // first, count, u_snap, the image's index in the batch
};
layout(std430, binding = BIND_POINTS) readonly buffer MLSBatchImages {
    MLSBatchImage mls_batch_image[];
};
#if MLS_UBO_CAPACITY
// the handles of every image of the dispatch in one uniform block (llvmpipe reads a uniform
// block at an index alike in every lane faster than a storage buffer)
layout(std140, binding = BIND_HANDLES_BLOCK) uniform MLSHandles {
    vec4 mls_handles[MLS_UBO_CAPACITY];
};
#else
layout(std430, binding = BIND_HANDLES) readonly buffer MLSHandles {
    vec4 mls_handles[];
};
#endif
uniform int u_batch_stride;   // vec2 items (lattice points, or a list's) from one image to the next
float u_log2_s;
float u_radius;
float u_hit2;
bool u_snap;
vec2 u_lattice_origin;
vec2 u_lattice_step;
vec2 u_lattice_last;
vec2 u_center;
float u_scale;
int mls_batch_first;
int mls_batch_count;
int mls_batch_image_index;

int mls_handle_count() {
    return mls_batch_count;
}

vec4 mls_handle(int i) {
    return mls_handles[mls_batch_first + i];
}

// Take row ``row`` of the image table.
void mls_batch_begin(int row) {
    MLSBatchImage image = mls_batch_image[row];
    u_lattice_origin = image.lattice.xy;
    u_lattice_last = image.lattice.zw;
    u_lattice_step = image.weights.xx;
    u_log2_s = image.weights.y;
    u_radius = image.weights.z;
    u_hit2 = image.weights.w;
    u_center = image.frame.xy;
    u_scale = image.frame.z;
    mls_batch_first = image.handles.x;
    mls_batch_count = image.handles.y;
    u_snap = image.handles.z != 0;
    mls_batch_image_index = image.handles.w;
}
#endif
