// The pass over a deformed mesh's faces (glmls.core.mesh3.face_folds), MESH3_FACES faces per
// invocation, each face's records (mls3/points.comp.glsl, MLS3_MESH; their table) read once:
//   the fold flags: a face folds where one of its vertices does (det J <= 0), or where its
//     deformed normal points against its original normal carried by the sum of its
//     vertices' cofactor matrices, n (C_a + C_b + C_c); one byte each (0 or 1), the
//     invocation's 4 in one uint;
//   MESH3_NORMAL_SUMS: the face's normal added at each corner in fixed point of the scale
//     in the vertex's sums (mls3/mesh.glsl; atomicAdd of ints: core GL has no float
//     atomics, and integer sums do not depend on the order).
layout(local_size_x = LOCAL_SIZE) in;

#define MESH3_FACE_PASS
#include "mls3/mesh.glsl"

#ifndef MESH3_NORMAL_SUMS
#define MESH3_NORMAL_SUMS 0
#endif

layout(std430, binding = BIND_MESH_FOLDS) writeonly buffer Mesh3Folds {
    uint mesh3_folds[];
};
#if MESH3_NORMAL_SUMS
layout(std430, binding = BIND_MESH_NORMALS) buffer Mesh3Sums {
    int mesh3_sums[];
};
#endif

bool mesh3_face(ivec3 corners) {
    vec3 v[3];
    vec3 f[3];
    mat3 cofactors = mat3(0.0);
    bool folded = false;
    for (int c = 0; c < 3; ++c) {
        int at = 4 * corners[c];
        vec4 r0 = TABLE_FETCH(mesh3_records, at), r1 = TABLE_FETCH(mesh3_records, at + 1);
        vec4 r2 = TABLE_FETCH(mesh3_records, at + 2), r3 = TABLE_FETCH(mesh3_records, at + 3);
        v[c] = r0.xyz;
        f[c] = v[c] + vec3(r0.w, r1.xy);
        cofactors += mesh3_cofactor(mesh3_rows(r1, r2, r3));
        folded = folded || r3.w <= 0.0;
    }
    vec3 before = cross(v[1] - v[0], v[2] - v[0]);
    vec3 after = cross(f[1] - f[0], f[2] - f[0]);
#if MESH3_NORMAL_SUMS
    for (int c = 0; c < 3; ++c) {
        int at = MESH3_SUMS * corners[c];
        float largest = intBitsToFloat(mesh3_sums[at]);
        if (largest > 0.0) {
            // |before / largest| <= 1: the sum of the vertex's faces stays within 2^30
            float faces = float(mesh3_sums[at + 1]);
            ivec3 q = ivec3(round(before / largest * (1073741824.0 / faces)));
            at += MESH3_SUM_AT;
            atomicAdd(mesh3_sums[at], q.x);
            atomicAdd(mesh3_sums[at + 1], q.y);
            atomicAdd(mesh3_sums[at + 2], q.z);
        }
    }
#endif
    // before (C_a + C_b + C_c): the columns of ``cofactors`` are the matrices' rows
    return folded || dot(after, cofactors * before) <= 0.0;
}

void main() {
    int first = u_offset + MESH3_FACES * int(gl_GlobalInvocationID.x);
    if (first >= u_count) {
        return;
    }
    ivec3 faces[MESH3_FACES];
    mesh3_faces_from(first, faces);
    uint flags = 0u;
    for (int q = 0; q < MESH3_FACES; ++q) {
        if (first + q < u_count && mesh3_face(faces[q])) {
            flags |= 1u << (8 * q);
        }
    }
    mesh3_folds[first / 4] = flags;
}
