// The cells method, first pass: every cell of a band of the lattice (one invocation each)
// tests the output voxel centres in the bounding box of each of its 6 deformed tetrahedra,
// within the output slab, and keeps its key (its index in scan order of the source) in each
// voxel it contains by atomicMin: once every band has run, a voxel holds the FIRST cell
// (smallest (z, y, x)) that covers it, whatever the order the cells ran in.
layout(local_size_x = LOCAL_SIZE) in;

#include "volume/lattice.glsl"
#include "volume/tetra.glsl"

layout(std430, binding = BIND_VOLUME_KEYS) buffer VolumeKeys {
    uint volume_keys[];
};

uniform int u_offset;       // first item of this dispatch
uniform int u_count;        // cells of the band
uniform int u_cell_first;   // the band's first layer of cells
uniform ivec3 u_slab_size;  // W, H and slices of the output slab
uniform vec3 u_slab_origin; // source voxels that the slab's voxel (0, 0, 0) shows

void main() {
    int item = u_offset + int(gl_GlobalInvocationID.x);
    if (item >= u_count) {
        return;
    }
    ivec3 cells = u_lattice_dims - 1;
    ivec3 cell = ivec3(item % cells.x, (item / cells.x) % cells.y,
                       item / (cells.x * cells.y) + u_cell_first);
    vec3 q[8];
    vec3 low = vec3(1e30);
    vec3 high = vec3(-1e30);
    for (int c = 0; c < 8; ++c) {
        q[c] = volume_deformed(volume_corner(cell, c)) - u_slab_origin;
        low = min(low, q[c]);
        high = max(high, q[c]);
    }
    if (any(isnan(low)) || any(isnan(high)) || any(isinf(low)) || any(isinf(high))) {
        return;
    }
    ivec3 last = u_slab_size - 1;
    if (any(greaterThan(low, vec3(last) + 0.5)) || any(lessThan(high, vec3(-0.5)))) {
        return;
    }
    uint key = volume_key_of(cell);
    for (int t = 0; t < 6; ++t) {
        vec3 a = q[0];
        vec3 b = q[VOLUME_TETRA[2 * t]];
        vec3 c = q[VOLUME_TETRA[2 * t + 1]];
        vec3 d = q[7];
        ivec3 lo = max(ivec3(ceil(min(min(a, b), min(c, d)) - VOLUME_INSIDE_EPS)), ivec3(0));
        ivec3 hi = min(ivec3(floor(max(max(a, b), max(c, d)) + VOLUME_INSIDE_EPS)), last);
        for (int z = lo.z; z <= hi.z; ++z) {
            for (int y = lo.y; y <= hi.y; ++y) {
                for (int x = lo.x; x <= hi.x; ++x) {
                    vec3 l;
                    if (volume_barycentric(a, b, c, d, vec3(x, y, z), l) && volume_inside(l)) {
                        atomicMin(volume_keys[(z * u_slab_size.y + y) * u_slab_size.x + x], key);
                    }
                }
            }
        }
    }
}
