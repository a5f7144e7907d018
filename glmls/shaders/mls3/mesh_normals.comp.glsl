// The area-weighted vertex normals of a mesh, one invocation per face, in two stages over the
// normal sums (mls3/mesh.glsl; zeros before stage 0):
//   MESH3_NORMALS_STAGE 0: at each corner, the largest |component| of the face's normal
//     (b - a) x (c - a) (atomicMax of its float bits: non-negative floats order as their
//     bits do) and one more face;
//   MESH3_NORMALS_STAGE 1: the normal added at each corner in fixed point (atomicAdd of ints:
//     core GL has no float atomics, and integer sums do not depend on the order).
// Vertices scaled (mls3/points.comp.glsl's input), 3 floats each.
layout(local_size_x = LOCAL_SIZE) in;

#include "mls3/mesh.glsl"

layout(std430, binding = BIND_POINTS) readonly buffer Mesh3Vertices {
    float mesh3_vertices[];
};
layout(std430, binding = BIND_MESH_NORMALS) buffer Mesh3Sums {
    int mesh3_sums[];
};
uniform int u_count;     // faces
uniform int u_offset;    // first face of this dispatch

vec3 mesh3_vertex(int k) {
    return vec3(mesh3_vertices[3 * k], mesh3_vertices[3 * k + 1], mesh3_vertices[3 * k + 2]);
}

void main() {
    int face = u_offset + int(gl_GlobalInvocationID.x);
    if (face >= u_count) {
        return;
    }
    ivec3 corners = mesh3_face(face);
    vec3 a = mesh3_vertex(corners.x);
    vec3 n = cross(mesh3_vertex(corners.y) - a, mesh3_vertex(corners.z) - a);
    for (int c = 0; c < 3; ++c) {
        int at = MESH3_SUMS * corners[c];
#if MESH3_NORMALS_STAGE == 0
        atomicMax(mesh3_sums[at], floatBitsToInt(max(max(abs(n.x), abs(n.y)), abs(n.z))));
        atomicAdd(mesh3_sums[at + 1], 1);
#else
        float largest = intBitsToFloat(mesh3_sums[at]);
        if (largest > 0.0) {
            // |n / largest| <= 1: the sum of the vertex's faces stays within 2^30
            ivec3 q = ivec3(round(n / largest * (1073741824.0 / float(mesh3_sums[at + 1]))));
            atomicAdd(mesh3_sums[at + 2], q.x);
            atomicAdd(mesh3_sums[at + 3], q.y);
            atomicAdd(mesh3_sums[at + 4], q.z);
        }
#endif
    }
}
