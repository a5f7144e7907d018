// The backward method's fold pass, its first stage (glmls.volume.folds): for each voxel of
// the output slab, its source point as Newton's passes left it, copied from the window
// (volume/neighbours.glsl) into the coordinates buffer; a voxel left without one is listed
// (BIND_RESCUE) for volume/folds.comp.glsl where volume_listed says so. The starts are
// volume/folds.comp.glsl's to find: a CPU renderer runs the code of a branch for every voxel
// whatever its lanes. VOLUME_LIST_ITEMS consecutive voxels an invocation, listed together.
#ifndef VOLUME_LIST_ITEMS
#define VOLUME_LIST_ITEMS 16
#endif

layout(local_size_x = LOCAL_SIZE) in;

#include "volume/neighbours.glsl"
#include "volume/slab.glsl"

layout(std430, binding = BIND_VOLUME_COORDS) writeonly buffer VolumeCoords {
    vec4 volume_coords[];
};
#define SECOND_PASS_ITEM uint
#include "common/second_pass.glsl"

uniform int u_offset;        // first item of this dispatch
uniform int u_count;         // voxels of the slab
uniform ivec3 u_slab_first;  // the slab's first output voxel (x, y, z)
uniform float u_accept;

void main() {
    int first = u_offset + int(gl_GlobalInvocationID.x) * VOLUME_LIST_ITEMS;
    uint listed = 0u;   // bit j: voxel first + j
    for (int j = 0; j < VOLUME_LIST_ITEMS; ++j) {
        int i = min(first + j, u_count - 1);   // past the end: the last voxel, unlisted
        ivec3 v = u_slab_first + volume_voxel(i);
        vec4 own = volume_neighbours[volume_window_index(v)];
        volume_coords[i] = own;
        bool start = first + j < u_count && own.w < 0.0 && volume_listed(v, own, u_accept);
        listed |= start ? 1u << uint(j) : 0u;
    }
    if (listed != 0u) {
        // every voxel has room (the list holds the slab's)
        uint k = second_pass_slots(uint(bitCount(listed)));
        for (; listed != 0u; listed &= listed - 1u) {
            if (k < u_rescue_capacity) {
                second_pass_items[k] = uint(first + findLSB(listed));
            }
            ++k;
        }
    }
}
