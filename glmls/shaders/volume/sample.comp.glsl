// The backward method's last pass: every output voxel of the slab samples the source at the
// point in the coordinates buffer ((x, y, z, w): w >= 0 covered), or gets the background. Over
// a source held in pieces, one pass per box of the voxels the points read first
// (volume_first_voxel): a voxel is sampled in the pass whose box holds its first voxel, and
// an uncovered one in the pass told to write those.
layout(local_size_x = LOCAL_SIZE) in;

#include "volume/sample.glsl"
#include "volume/target.glsl"
#include "volume/slab.glsl"

layout(std430, binding = BIND_VOLUME_COORDS) readonly buffer VolumeCoords {
    vec4 volume_coords[];
};

uniform int u_offset;        // first item of this dispatch
uniform int u_count;         // voxels of the slab
uniform vec4 u_background;
uniform ivec3 u_first_low;   // the box of first voxels this pass samples
uniform ivec3 u_first_high;
uniform bool u_write_uncovered;

void main() {
    int i = u_offset + int(gl_GlobalInvocationID.x);
    if (i >= u_count) {
        return;
    }
    ivec3 p = volume_voxel(i);
    vec4 c = volume_coords[i];
    if (c.w < 0.0) {
        if (u_write_uncovered) {
            volume_store(p, u_background);
        }
        return;
    }
    ivec3 first = volume_first_voxel(c.xyz);
    if (all(greaterThanEqual(first, u_first_low)) && all(lessThanEqual(first, u_first_high))) {
        volume_store(p, volume_sample(c.xyz));
    }
}
