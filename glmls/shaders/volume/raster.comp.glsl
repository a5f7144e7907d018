// The cells method, first pass: every cell of a band of the lattice (one invocation each)
// finds the output voxel centres inside each of its 6 deformed tetrahedra, within the output
// slab (along each row of the tetrahedron's bounding box, the interval where its 4
// barycentric coordinates, affine in x, are all >= -VOLUME_INSIDE_EPS), and keeps its key (6
// times its rank, volume_key_of, plus the tetrahedron's) in each voxel it contains by
// atomicMin: once every band has run, a voxel holds the FIRST cell (smallest (z, y, x), the
// margin's after the volume's where u_lattice_box_first) that covers it, and its first
// tetrahedron that does, whatever the order the cells ran in.
layout(local_size_x = LOCAL_SIZE) in;

#include "volume/lattice.glsl"
#include "volume/tetra.glsl"
// A cell too large for one invocation on a driver that caps its loops (llvmpipe) is walked
// in pieces, tiles of its voxel box, by more invocations: per voxel of a tile at most one
// step of each of its 6 tetrahedra, per row 6 times the 4 bounds and a step
#define SCAN_PIECE_COST 4
#define SCAN_PIECE_ROW_COST 40
#include "common/pieces.glsl"

layout(std430, binding = BIND_VOLUME_KEYS) buffer VolumeKeys {
    uint volume_keys[];
};

uniform int u_offset;       // first item of this dispatch
uniform int u_count;        // cells of the band
uniform int u_cell_first;   // the band's first layer of cells
uniform ivec3 u_slab_size;  // W, H and slices of the output slab
// source voxels that the output's voxel (0, 0, 0) shows, and the slab's first output voxel
// (x, y, z; a box of the output where its slices exceed a texture or a storage buffer):
// every place is taken relative to the output's origin, not the slab's, so that a voxel's
// float32 arithmetic is the same whatever slab it falls in
uniform vec3 u_frame_origin;
uniform ivec3 u_slab_first;

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
        q[c] = volume_deformed(volume_corner(cell, c)) - u_frame_origin;
        low = min(low, q[c]);
        high = max(high, q[c]);
    }
    if (any(isnan(low)) || any(isnan(high)) || any(isinf(low)) || any(isinf(high))) {
        return;
    }
    ivec3 first = u_slab_first;
    ivec3 last = first + u_slab_size - 1;
    if (any(greaterThan(low, vec3(last) + 0.5)) || any(lessThan(high, vec3(first) - 0.5))) {
        return;
    }
    // this invocation's piece of the cell's voxels (on llvmpipe; elsewhere the slab, which
    // holds every tetrahedron's box); each tetrahedron's arithmetic is the same whatever
    // piece its voxels are walked in
#if SCAN_PIECE_PIXELS
    ivec3 piece_first = ivec3(max(ceil(low - VOLUME_INSIDE_EPS), vec3(first)));
    ivec3 piece_last = ivec3(min(floor(high + VOLUME_INSIDE_EPS), vec3(last)));
    if (!scan_piece_3d(piece_first, piece_last)) {
        return;
    }
#else
    ivec3 piece_first = first;
    ivec3 piece_last = last;
#endif
    uint first_key = 6u * volume_key_of(cell);
    for (int t = 0; t < 6; ++t) {
        uint key = first_key + uint(t);
        vec3 a = q[0];
        vec3 e1 = q[VOLUME_TETRA[2 * t]] - a;
        vec3 e2 = q[VOLUME_TETRA[2 * t + 1]] - a;
        vec3 e3 = q[7] - a;
        // the barycentric coordinates are affine in p: l_i = dot(p - a, g_i), l_0 = 1 - sum
        vec3 n1 = cross(e2, e3);
        float det = dot(e1, n1);
        if (!(abs(det) > 1e-7 * length(e1) * length(e2) * length(e3))) {
            continue;   // flat
        }
        vec3 g1 = n1 / det;
        vec3 g2 = cross(e3, e1) / det;
        vec3 g3 = cross(e1, e2) / det;
        vec3 gx = vec3(g1.x, g2.x, g3.x);   // d l / dx
        float g0x = -(gx.x + gx.y + gx.z);
        vec3 tlo = min(min(a, a + e1), min(a + e2, a + e3));
        vec3 thi = max(max(a, a + e1), max(a + e2, a + e3));
        // clamped to the slab as floats, then made ints: a corner far outside (a float past
        // the int range) has no defined int, and x86 (llvmpipe) makes INT_MIN of it
        ivec3 lo = ivec3(max(ceil(tlo - VOLUME_INSIDE_EPS), vec3(first)));
        ivec3 hi = ivec3(min(floor(thi + VOLUME_INSIDE_EPS), vec3(last)));
        for (int z = max(lo.z, piece_first.z); z <= min(hi.z, piece_last.z); ++z) {
            for (int y = max(lo.y, piece_first.y); y <= min(hi.y, piece_last.y); ++y) {
                // along the row: l_i(x) = c_i + gx_i (x - lo.x), all >= -eps on an interval
                vec3 r = vec3(float(lo.x), float(y), float(z)) - a;
                vec3 c = vec3(dot(r, g1), dot(r, g2), dot(r, g3));
                float c0 = 1.0 - c.x - c.y - c.z;
                float from = 0.0;
                float to = float(hi.x - lo.x);
                for (int i = 0; i < 4; ++i) {
                    float ci = i == 3 ? c0 : c[i];
                    float gi = i == 3 ? g0x : gx[i];
                    float bound = (-VOLUME_INSIDE_EPS - ci) / gi;
                    if (gi > 0.0) {
                        from = max(from, bound);
                    } else if (gi < 0.0) {
                        to = min(to, bound);
                    } else if (ci < -VOLUME_INSIDE_EPS) {
                        to = -1.0;
                    }
                }
                // the interval, a voxel wider each side (its ends are divisions by slopes
                // that rounding may leave near 0), clamped to the row before it becomes an
                // int; each voxel in it tested itself, so that one on a face shared by two
                // tetrahedra (within VOLUME_INSIDE_EPS of both) is in at least one
                float span = float(hi.x - lo.x);
                int x0 = lo.x + int(ceil(clamp(from, 0.0, span + 1.0))) - 1;
                int x1 = lo.x + int(floor(clamp(to, -1.0, span))) + 1;
                int row = ((z - first.z) * u_slab_size.y + y - first.y) * u_slab_size.x - first.x;
                int x_end = min(min(x1, hi.x), piece_last.x);
                for (int x = max(max(x0, lo.x), piece_first.x); x <= x_end; ++x) {
                    float dx = float(x - lo.x);
                    vec4 l = vec4(c + gx * dx, c0 + g0x * dx);
                    if (min(min(l.x, l.y), min(l.z, l.w)) >= -VOLUME_INSIDE_EPS) {
                        atomicMin(volume_keys[row + x], key);
                    }
                }
            }
        }
    }
}
