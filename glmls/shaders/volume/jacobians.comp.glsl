// The backward method's first guess, to second order: at each lattice point of z layers
// u_first_layer .. of the band held in the lattice buffer (with its neighbours in z), f's
// Jacobian J by central differences of f at the neighbouring points (one-sided at the
// lattice's ends), inverted: texel (3 x + c, y, z - u_band_first) holds (column c of J^-1,
// f's component c), all that the resolve pass reads of a corner. J^-1 is 0 where J is singular or not a number (the resolve pass then
// keeps the linear guess). Matrices act on column vectors here, as in the resolve and Newton
// passes: df = J dx.
layout(local_size_x = LOCAL_SIZE) in;

#include "volume/lattice.glsl"

layout(rgba32f, binding = BIND_VOLUME_JACOBIANS_OUT) writeonly uniform image3D u_jacobians_out;

uniform int u_offset;       // first item of this dispatch
uniform int u_count;        // points of the layers
uniform int u_first_layer;  // the first layer of points computed

// J's column along axis k at point a: its neighbours' difference over their distance
vec3 volume_jacobian_column(ivec3 a, int k) {
    ivec3 unit = ivec3(equal(ivec3(k), ivec3(0, 1, 2)));
    ivec3 lo = max(a - unit, ivec3(0));
    ivec3 hi = min(a + unit, u_lattice_dims - 1);
    float span = volume_lattice_point(hi)[k] - volume_lattice_point(lo)[k];
    return (volume_deformed(hi) - volume_deformed(lo)) / span;
}

void main() {
    int item = u_offset + int(gl_GlobalInvocationID.x);
    if (item >= u_count) {
        return;
    }
    int nx = u_lattice_dims.x;
    int ny = u_lattice_dims.y;
    ivec3 a = ivec3(item % nx, (item / nx) % ny, item / (nx * ny) + u_first_layer);
    mat3 J = mat3(volume_jacobian_column(a, 0), volume_jacobian_column(a, 1),
                  volume_jacobian_column(a, 2));
    float det = determinant(J);
    // f's Jacobian in voxels per voxel: a determinant this small is a fold's edge
    mat3 G = abs(det) > 1e-6 && abs(det) < 1e30 ? inverse(J) : mat3(0.0);
    vec3 f = volume_deformed(a);
    ivec3 t = ivec3(3 * a.x, a.y, a.z - u_band_first);
    imageStore(u_jacobians_out, t, vec4(G[0], f.x));
    imageStore(u_jacobians_out, t + ivec3(1, 0, 0), vec4(G[1], f.y));
    imageStore(u_jacobians_out, t + ivec3(2, 0, 0), vec4(G[2], f.z));
}
