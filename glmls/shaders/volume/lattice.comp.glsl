// f at the points of a band of z layers of the lattice of voxel corners (volume/lattice.glsl),
// from layer u_first_layer, into the band buffer (3 floats a point, source voxels).
layout(local_size_x = LOCAL_SIZE) in;

#define VOLUME_LATTICE_WRITE 1
#include "volume/field.glsl"
#include "volume/lattice.glsl"

uniform int u_offset;       // first item of this dispatch
uniform int u_count;        // points of the band
uniform int u_first_layer;

void main() {
    // No early return past the end (as mls3/points.comp.glsl): those lanes redo the last
    // point and store nothing.
    int item = u_offset + int(gl_GlobalInvocationID.x);
    bool store = item < u_count;
    int i = min(item, u_count - 1);
    int nx = u_lattice_dims.x;
    int ny = u_lattice_dims.y;
    ivec3 a = ivec3(i % nx, (i / nx) % ny, i / (nx * ny) + u_first_layer);
    vec3 f = volume_f(volume_lattice_point(a));
    if (store) {
        volume_lattice_f[3 * i] = f.x;
        volume_lattice_f[3 * i + 1] = f.y;
        volume_lattice_f[3 * i + 2] = f.z;
    }
}
