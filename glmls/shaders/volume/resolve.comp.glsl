// The cells method, second pass: every output voxel of the slab (one invocation each) whose
// first cell (the raster pass's key: 6 cell + tetrahedron) is in the band takes the source
// point at its place in that tetrahedron, interpolated linearly from its source corners; then
//   VOLUME_COORDS 0: samples the source there (volume/sample.glsl; nearest keeps to the
//                    cell's own voxels) into the slab image (volume/target.glsl);
//                 1: writes the point (x, y, z, 0) into the coordinates buffer, the first
//                    guess of the backward method ((0, 0, 0, -1): no cell), and the
//                    tetrahedron's linear map from output to source into the slopes;
//                    VOLUME_HERMITE 1: the guess to second order from f's inverse Jacobians
//                    G_k at the tetrahedron's corners (volume/jacobians.comp.glsl): with
//                    barycentric l_k, g(u) = sum l_k (x_k + G_k (u - y_k) / 2) + O(h^3)
//                    (y_k = f(x_k): the linear interpolation's error and the corners' Taylor
//                    expansions' are equal and opposite to second order), and the slope
//                    sum l_k G_k.
// Voxels no cell covers get the background (-1 in the coordinates), in the pass told to.
layout(local_size_x = LOCAL_SIZE) in;

#ifndef VOLUME_SOURCE_TILES
#define VOLUME_SOURCE_TILES 0
#endif

#include "volume/lattice.glsl"
#include "volume/slab.glsl"
#include "volume/tetra.glsl"

#if VOLUME_COORDS
layout(std430, binding = BIND_VOLUME_COORDS) writeonly buffer VolumeCoords {
    vec4 volume_coords[];
};
// the tetrahedron's linear map from output to source offsets (3 columns a voxel): the
// Jacobian of the piecewise linear inverse, which Newton's method starts with
layout(std430, binding = BIND_VOLUME_SLOPES) writeonly buffer VolumeSlopes {
    vec4 volume_slopes[];
};
#if VOLUME_HERMITE
layout(binding = BIND_VOLUME_JACOBIANS) uniform sampler3D u_volume_jacobians;

// f and G (f's inverse Jacobian, column vectors) at lattice point a of the band, from the
// texture (texel fetches: on llvmpipe far cheaper than the storage buffer's loads); false
// where G is not known (0: J singular there)
bool volume_vertex(ivec3 a, out vec3 f, out mat3 G) {
    ivec3 t = ivec3(3 * a.x, a.y, a.z - u_band_first);
    vec4 c0 = texelFetch(u_volume_jacobians, t, 0);
    vec4 c1 = texelFetch(u_volume_jacobians, t + ivec3(1, 0, 0), 0);
    vec4 c2 = texelFetch(u_volume_jacobians, t + ivec3(2, 0, 0), 0);
    f = vec3(c0.w, c1.w, c2.w);
    G = mat3(c0.xyz, c1.xyz, c2.xyz);
    return G[0] != vec3(0.0) || G[1] != vec3(0.0) || G[2] != vec3(0.0);
}
#endif
#else
#include "volume/sample.glsl"
#include "volume/target.glsl"
uniform vec4 u_background;
#endif

layout(std430, binding = BIND_VOLUME_KEYS) readonly buffer VolumeKeys {
    uint volume_keys[];
};

uniform int u_offset;        // first item of this dispatch
uniform int u_count;         // voxels of the slab
uniform vec3 u_frame_origin; // source voxels that the output's voxel (0, 0, 0) shows
uniform ivec3 u_slab_first;  // the slab's first output voxel (x, y, z)
uniform uint u_key_first;    // the band's cells: keys u_key_first .. u_key_end - 1
uniform uint u_key_end;
#if VOLUME_SOURCE_TILES
// and of those, the cells x .. y - 1 of a row and z .. w - 1 of a layer: a piece whose voxels
// one texture holds, where the source's slices exceed one
uniform ivec4 u_cell_rows;
#endif
uniform bool u_write_uncovered;
uniform ivec3 u_volume_size; // W, H, D of the source volume

void volume_write(int i, ivec3 p, vec3 s, bool covered, ivec3 lo, ivec3 hi) {
#if VOLUME_COORDS
    volume_coords[i] = covered ? vec4(s, 0.0) : vec4(0.0, 0.0, 0.0, -1.0);
#elif WARP_LINEAR
    volume_store(p, covered ? volume_sample(s) : u_background);
#else
    volume_store(p, covered ? volume_texel(clamp(ivec3(floor(s + 0.5)), lo, hi)) : u_background);
#endif
}

void main() {
    int i = u_offset + int(gl_GlobalInvocationID.x);
    if (i >= u_count) {
        return;
    }
    ivec3 p = volume_voxel(i);
    uint key = volume_keys[i];
    if (key == 0xFFFFFFFFu) {
        if (u_write_uncovered) {
            volume_write(i, p, vec3(0.0), false, ivec3(0), ivec3(0));
        }
        return;
    }
    uint cell_key = volume_index_of(key / 6u);
    if (cell_key < u_key_first || cell_key >= u_key_end) {
        return;
    }
    ivec3 cell = volume_cell_of(cell_key);
#if VOLUME_SOURCE_TILES
    if (cell.x < u_cell_rows.x || cell.x >= u_cell_rows.y || cell.y < u_cell_rows.z ||
        cell.y >= u_cell_rows.w) {
        return;
    }
#endif
    int best = int(key % 6u);
    ivec3 b = volume_corner(cell, VOLUME_TETRA[2 * best]);
    ivec3 c = volume_corner(cell, VOLUME_TETRA[2 * best + 1]);
    ivec3 d = cell + ivec3(1);
    // f at the corners, as the raster pass read them (the texture holds the same floats)
#if VOLUME_HERMITE
    mat3 g0, gb, gc, gd;
    vec3 y0, yb, yc, yd;
    bool known = volume_vertex(cell, y0, g0);
    known = volume_vertex(b, yb, gb) && known;
    known = volume_vertex(c, yc, gc) && known;
    known = volume_vertex(d, yd, gd) && known;
#else
    vec3 y0 = volume_deformed(cell), yb = volume_deformed(b), yc = volume_deformed(c);
    vec3 yd = volume_deformed(d);
#endif
    vec3 coords;
    // as the raster pass: corners and voxel relative to the output's origin
    vec3 u = vec3(p + u_slab_first);
    volume_barycentric(y0 - u_frame_origin, yb - u_frame_origin, yc - u_frame_origin,
                       yd - u_frame_origin, u, coords);
    vec3 s0 = volume_lattice_point(cell);
    vec3 s = s0 + coords.x * (volume_lattice_point(b) - s0) +
             coords.y * (volume_lattice_point(c) - s0) +
             coords.z * (volume_lattice_point(d) - s0);
    // nearest keeps to the cell's own voxels (its voxel centres, margin included)
    ivec3 lo = cell * u_lattice_grid + u_lattice_voxel_first;
    ivec3 hi = min(lo + u_lattice_grid - 1, u_lattice_voxel_end - 1);
#if VOLUME_COORDS
    mat3 slope;
    bool linear = true;
#if VOLUME_HERMITE
    gb -= g0;
    gc -= g0;
    gd -= g0;
    // sum l_k G_k (u - y_k) / 2 without the G_0 sum l_k (u - y_k) = 0 that it contains, so
    // that equal G_k (an affine f, the identity) leave the linear guess exactly; u - y_k
    // relative to the output's origin, as the barycentric coordinates
    vec3 correction = 0.5 * (coords.x * (gb * (u - (yb - u_frame_origin))) +
                             coords.y * (gc * (u - (yc - u_frame_origin))) +
                             coords.z * (gd * (u - (yd - u_frame_origin))));
    // a correction of a quarter grid step or more is no second-order term: a fold's
    // neighbourhood, where the linear guess is the safer start
    if (known && length(correction) < 0.25 * float(u_lattice_grid)) {
        s += correction;
        slope = g0 + coords.x * gb + coords.y * gc + coords.z * gd;
        linear = false;
    }
#endif
    if (linear) {
        // d s / d p = S E^-1: source edges over deformed edges
        mat3 deformed = mat3(yb - y0, yc - y0, yd - y0);
        mat3 source = mat3(volume_lattice_point(b) - s0, volume_lattice_point(c) - s0,
                           volume_lattice_point(d) - s0);
        slope = abs(determinant(deformed)) > 0.0 ? source * inverse(deformed) : mat3(0.0);
    }
    volume_slopes[3 * i] = vec4(slope[0], 0.0);
    volume_slopes[3 * i + 1] = vec4(slope[1], 0.0);
    volume_slopes[3 * i + 2] = vec4(slope[2], 0.0);
#endif
    volume_write(i, p, s, true, lo, hi);
}
