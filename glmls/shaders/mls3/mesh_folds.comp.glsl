// The folded faces of a deformed mesh (glmls.core.mesh3.face_folds): a face folds where one
// of its vertices does (det J <= 0), or where its deformed normal points against its
// original normal carried by the sum of its vertices' cofactor matrices, n (C_a + C_b + C_c).
// Reads the vertices (scaled, 3 floats each) and their records (mls3/points.comp.glsl,
// MLS3_MESH); each invocation writes 4 faces' flags (0 or 1), one byte each, in one uint.
layout(local_size_x = LOCAL_SIZE) in;

#include "mls3/mesh.glsl"

layout(std430, binding = BIND_POINTS) readonly buffer Mesh3Vertices {
    float mesh3_vertices[];
};
layout(std430, binding = BIND_DEFORMED) readonly buffer Mesh3Records {
    float mesh3_records[];
};
layout(std430, binding = BIND_MESH_FOLDS) writeonly buffer Mesh3Folds {
    uint mesh3_folds[];
};
uniform int u_count;     // faces
uniform int u_offset;    // first face of this dispatch

vec3 mesh3_vertex(int k) {
    return vec3(mesh3_vertices[3 * k], mesh3_vertices[3 * k + 1], mesh3_vertices[3 * k + 2]);
}

// 3 floats of vertex k's record from ``at``
vec3 mesh3_record(int k, int at) {
    int i = MESH3_RECORD * k + at;
    return vec3(mesh3_records[i], mesh3_records[i + 1], mesh3_records[i + 2]);
}

bool mesh3_folds_at(int face) {
    ivec3 corners = mesh3_face(face);
    vec3 v[3];
    vec3 f[3];
    mat3 cofactors = mat3(0.0);
    bool folded = false;
    for (int c = 0; c < 3; ++c) {
        int k = corners[c];
        v[c] = mesh3_vertex(k);
        f[c] = v[c] + mesh3_record(k, 0);
        cofactors += mesh3_cofactor(mat3(mesh3_record(k, 3), mesh3_record(k, 6),
                                         mesh3_record(k, 9)));
        folded = folded || mesh3_records[MESH3_RECORD * k + 15] <= 0.0;
    }
    vec3 before = cross(v[1] - v[0], v[2] - v[0]);
    vec3 after = cross(f[1] - f[0], f[2] - f[0]);
    // before (C_a + C_b + C_c): the columns of ``cofactors`` are the matrices' rows
    return folded || dot(after, cofactors * before) <= 0.0;
}

void main() {
    int first = u_offset + 4 * int(gl_GlobalInvocationID.x);
    if (first >= u_count) {
        return;
    }
    uint flags = 0u;
    for (int q = 0; q < 4; ++q) {
        if (first + q < u_count && mesh3_folds_at(first + q)) {
            flags |= 1u << (8 * q);
        }
    }
    mesh3_folds[first / 4] = flags;
}
