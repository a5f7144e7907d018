// The scale of each vertex's sum of face normals (mls3/mesh.glsl's normal sums, zeros
// before), MESH3_FACES faces per invocation: at each corner of a face, the largest
// |component| of the face's normal (b - a) x (c - a) (atomicMax of its float bits:
// non-negative floats order as their bits do) and one more face. The faces pass
// (mls3/mesh_folds.comp.glsl) adds the normals in fixed point of that scale.
layout(local_size_x = LOCAL_SIZE) in;

#define MESH3_FACE_PASS
#include "mls3/mesh.glsl"

layout(std430, binding = BIND_MESH_NORMALS) buffer Mesh3Sums {
    int mesh3_sums[];
};

void main() {
    int first = u_offset + MESH3_FACES * int(gl_GlobalInvocationID.x);
    if (first >= u_count) {
        return;
    }
    ivec3 faces[MESH3_FACES];
    mesh3_faces_from(first, faces);
    for (int q = 0; q < MESH3_FACES; ++q) {
        if (first + q >= u_count) {
            break;
        }
        ivec3 corners = faces[q];
        vec3 a = mesh3_vertex(corners.x);
        vec3 n = cross(mesh3_vertex(corners.y) - a, mesh3_vertex(corners.z) - a);
        int largest = floatBitsToInt(max(max(abs(n.x), abs(n.y)), abs(n.z)));
        for (int c = 0; c < 3; ++c) {
            int at = MESH3_SUMS * corners[c];
            atomicMax(mesh3_sums[at], largest);
            atomicAdd(mesh3_sums[at + 1], 1);
        }
    }
}
