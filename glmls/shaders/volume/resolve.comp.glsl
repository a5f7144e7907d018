// The cells method, second pass: every output voxel of the slab (one invocation each) whose
// first cell (the raster pass's key: 6 cell + tetrahedron) is in the band takes the source
// point at its place in that tetrahedron, interpolated linearly from its source corners; then
//   VOLUME_COORDS 0: samples the source there (volume/sample.glsl; nearest keeps to the
//                    cell's own voxels) into the slab image (volume/target.glsl);
//                 1: writes the point (x, y, z, 0) into the coordinates buffer, the first
//                    guess of the backward method ((0, 0, 0, -1): no cell), and the
//                    tetrahedron's linear map from output to source into the slopes.
// Voxels no cell covers get the background (-1 in the coordinates), in the pass told to.
layout(local_size_x = LOCAL_SIZE) in;

#include "volume/lattice.glsl"
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
uniform ivec3 u_slab_size;   // W, H and slices of the output slab
uniform vec3 u_frame_origin; // source voxels that the output's voxel (0, 0, 0) shows
uniform int u_slab_first;    // the slab's first output slice
uniform uint u_key_first;    // the band's cells: keys u_key_first .. u_key_end - 1
uniform uint u_key_end;
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
    ivec3 p = ivec3(i % u_slab_size.x, (i / u_slab_size.x) % u_slab_size.y,
                    i / (u_slab_size.x * u_slab_size.y));
    uint key = volume_keys[i];
    if (key == 0xFFFFFFFFu) {
        if (u_write_uncovered) {
            volume_write(i, p, vec3(0.0), false, ivec3(0), ivec3(0));
        }
        return;
    }
    uint cell_key = key / 6u;
    if (cell_key < u_key_first || cell_key >= u_key_end) {
        return;
    }
    ivec3 cell = volume_cell_of(cell_key);
    int best = int(key % 6u);
    ivec3 b = volume_corner(cell, VOLUME_TETRA[2 * best]);
    ivec3 c = volume_corner(cell, VOLUME_TETRA[2 * best + 1]);
    vec3 coords;
    // as the raster pass: corners and voxel relative to the output's origin
    volume_barycentric(volume_deformed(cell) - u_frame_origin,
                       volume_deformed(b) - u_frame_origin, volume_deformed(c) - u_frame_origin,
                       volume_deformed(cell + ivec3(1)) - u_frame_origin,
                       vec3(p + ivec3(0, 0, u_slab_first)), coords);
    vec3 s0 = volume_lattice_point(cell);
    vec3 s = s0 + coords.x * (volume_lattice_point(b) - s0) +
             coords.y * (volume_lattice_point(c) - s0) +
             coords.z * (volume_lattice_point(cell + ivec3(1)) - s0);
    // nearest keeps to the cell's own voxels (its voxel centres, margin included)
    ivec3 lo = cell * u_lattice_grid - u_lattice_margin;
    ivec3 hi = min(lo + u_lattice_grid - 1, u_volume_size + u_lattice_margin - 1);
#if VOLUME_COORDS
    // d s / d p = S E^-1: source edges over deformed edges
    vec3 q0 = volume_deformed(cell);
    mat3 deformed = mat3(volume_deformed(b) - q0, volume_deformed(c) - q0,
                         volume_deformed(cell + ivec3(1)) - q0);
    mat3 source = mat3(volume_lattice_point(b) - s0, volume_lattice_point(c) - s0,
                       volume_lattice_point(cell + ivec3(1)) - s0);
    mat3 slope = abs(determinant(deformed)) > 0.0 ? source * inverse(deformed) : mat3(0.0);
    volume_slopes[3 * i] = vec4(slope[0], 0.0);
    volume_slopes[3 * i + 1] = vec4(slope[1], 0.0);
    volume_slopes[3 * i + 2] = vec4(slope[2], 0.0);
#endif
    volume_write(i, p, s, true, lo, hi);
}
