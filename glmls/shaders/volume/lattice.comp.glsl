// f at the points of a band of z layers of the lattice of voxel corners (volume/lattice.glsl),
// from layer u_first_layer, into the band buffer (3 floats a point, source voxels).
// VOLUME_LATTICE_STAGE 1 and 2 are two passes (glmls.gl.dispatch.SecondPass): the first takes
// only the solve's plain branch (mls3/solve.glsl, MLS3_SOLVE_LATER) and lists the points that
// need another, which the second computes with every branch.
#ifndef VOLUME_LATTICE_STAGE
#define VOLUME_LATTICE_STAGE 0
#endif
#if VOLUME_LATTICE_STAGE == 1 && !defined(MLS3_SOLVE_LATER)
#define MLS3_SOLVE_LATER 1
#endif
layout(local_size_x = LOCAL_SIZE) in;

#define VOLUME_LATTICE_WRITE 1
#include "volume/field.glsl"
#include "volume/lattice.glsl"

uniform int u_offset;       // first item of this dispatch
uniform int u_count;        // points of the band
uniform int u_first_layer;

#if VOLUME_LATTICE_STAGE
#define SECOND_PASS_ITEM uint
#include "common/second_pass.glsl"
#endif

// f at point i of the band, stored where ``store``
void volume_lattice_item(int i, bool store) {
    int nx = u_lattice_dims.x;
    int ny = u_lattice_dims.y;
    ivec3 a = ivec3(i % nx, (i / nx) % ny, i / (nx * ny) + u_first_layer);
    vec3 f = volume_f(volume_lattice_point(a));
#if VOLUME_LATTICE_STAGE == 1
    if (store && mls3_solve_later) {
        second_pass_items[second_pass_slot()] = uint(i);   // room for every point
    }
#endif
    if (store) {
        volume_lattice_f[3 * i] = f.x;
        volume_lattice_f[3 * i + 1] = f.y;
        volume_lattice_f[3 * i + 2] = f.z;
    }
}

#if VOLUME_LATTICE_STAGE == 2
void main() {
    // every listed point, however many the dispatch's work groups (at most u_max_groups)
    for (uint k = gl_GlobalInvocationID.x; k < second_pass_listed(); k += second_pass_stride()) {
        volume_lattice_item(int(second_pass_items[k]), true);
    }
}
#else
void main() {
    // No early return past the end (as mls3/points.comp.glsl): those lanes redo the last
    // point and store nothing.
    int item = u_offset + int(gl_GlobalInvocationID.x);
    volume_lattice_item(min(item, u_count - 1), item < u_count);
}
#endif
