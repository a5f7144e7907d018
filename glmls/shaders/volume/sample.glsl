// Samples the source volume (source voxels: centres at integers, (x, y, z) = (column, row,
// slice)) by texel fetches, so that uint8 and uint16 values stay exact:
//   WARP_LINEAR 0: the voxel containing the point; 1: trilinear between the 8 nearest voxel
//                  centres, in float32.
//   WARP_BORDER    the rule outside the volume (common/border.glsl; constant clamps).
//   VOLUME_INTEGER the source is an integer texture (uint8, uint16).
//   VOLUME_SOURCE_TILES 1: the texture holds a box of the source, runs of its columns and
//                  rows as of its slices (u_source_columns, u_source_rows), where its
//                  slices exceed one texture; 0: whole slices.
#include "common/blend.glsl"
#include "common/border.glsl"

#ifndef VOLUME_SOURCE_TILES
#define VOLUME_SOURCE_TILES 0
#endif

#if VOLUME_INTEGER
layout(binding = BIND_VOLUME_SOURCE) uniform usampler3D u_volume;
#else
layout(binding = BIND_VOLUME_SOURCE) uniform sampler3D u_volume;
#endif
uniform ivec3 u_source_size;   // W, H, D of the source
// the source slices the texture holds, one run after the other from its layer 0: slices x to
// y, then z to w (empty, z > w, where one run is held; two where wrap joins the last slice to
// the first, glmls.volume.texture.border_runs)
uniform ivec4 u_source_runs;
#if VOLUME_SOURCE_TILES
uniform ivec4 u_source_columns;  // the columns held, as the slices
uniform ivec4 u_source_rows;     // the rows held, as the slices
#endif

// the texel of index i (within the volume) of an axis whose indices ``runs`` holds
int volume_held(int i, ivec4 runs) {
    return i <= runs.y ? i - runs.x : runs.y - runs.x + 1 + i - runs.z;
}

vec4 volume_texel(ivec3 p) {
    int z = border_index(p.z, u_source_size.z);
    ivec3 q = ivec3(border_index(p.x, u_source_size.x), border_index(p.y, u_source_size.y),
                    volume_held(z, u_source_runs));
#if VOLUME_SOURCE_TILES
    q.x = volume_held(q.x, u_source_columns);
    q.y = volume_held(q.y, u_source_rows);
#endif
    return vec4(texelFetch(u_volume, q, 0));
}

// A sample point within VOLUME_SNAP of its coordinate's size (about 8 float32 roundings) of a
// voxel centre's plane is on that plane: the source points of the lattice's cells (cut short
// at the volume's sides) and of Newton's method carry float32 rounding, which trilinear
// weights would turn into values off by a few ulps where f copies voxels (the identity, a
// shift by whole voxels).
#define VOLUME_SNAP 1e-6


// s on the voxel centre planes it is within VOLUME_SNAP of
vec3 volume_snapped(vec3 s) {
    vec3 centre = floor(s + 0.5);
    return mix(s, centre, lessThanEqual(abs(s - centre), VOLUME_SNAP * max(abs(centre), vec3(8.0))));
}

// The first source voxel (x, y, z, before the border rule) that volume_sample(s) reads: the
// passes over a source held in pieces each take the voxels of a box of these
// (glmls.volume.construction), clamped to +-2^30 so that any float has an int
ivec3 volume_first_voxel(vec3 s) {
#if WARP_LINEAR
    vec3 first = floor(volume_snapped(s));
#else
    vec3 first = floor(s + 0.5);
#endif
    return ivec3(clamp(first, vec3(-1073741824.0), vec3(1073741824.0)));
}

vec4 volume_sample(vec3 s) {
#if WARP_LINEAR
    s = volume_snapped(s);
    vec3 corner = floor(s);
    vec3 t = s - corner;
    ivec3 p = ivec3(corner);
    vec4 c00 = sample_blend(volume_texel(p), volume_texel(p + ivec3(1, 0, 0)), t.x);
    vec4 c10 = sample_blend(volume_texel(p + ivec3(0, 1, 0)), volume_texel(p + ivec3(1, 1, 0)), t.x);
    vec4 c01 = sample_blend(volume_texel(p + ivec3(0, 0, 1)), volume_texel(p + ivec3(1, 0, 1)), t.x);
    vec4 c11 = sample_blend(volume_texel(p + ivec3(0, 1, 1)), volume_texel(p + ivec3(1, 1, 1)), t.x);
    return sample_blend(sample_blend(c00, c10, t.y), sample_blend(c01, c11, t.y), t.z);
#else
    return volume_texel(ivec3(floor(s + 0.5)));
#endif
}
