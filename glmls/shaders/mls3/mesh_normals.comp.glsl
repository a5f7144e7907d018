// The deformed unit normals of a mesh's vertices (mls3/mesh.glsl), one invocation per
// vertex, after the faces pass: the direction n of the sum of the faces' normals
// (mls3/mesh_folds.comp.glsl's MESH3_NORMAL_SUMS) or (MESH3_GIVEN_NORMALS) the vertex's own
// normal, carried by cof(J) with the sign of det J, n cof(J) sign(det J), J and det J from
// the vertex's record in its table; written over the vertex in the records' buffer.
layout(local_size_x = LOCAL_SIZE) in;

#include "mls3/mesh.glsl"

#ifndef MESH3_GIVEN_NORMALS
#define MESH3_GIVEN_NORMALS 0
#endif

#if MESH3_GIVEN_NORMALS
layout(std430, binding = BIND_MESH_NORMALS) readonly buffer Mesh3Normals {
    float mesh3_normals[];
};
#else
layout(std430, binding = BIND_MESH_NORMALS) readonly buffer Mesh3Sums {
    ivec4 mesh3_sums[];
};
#endif
layout(std430, binding = BIND_DEFORMED) writeonly buffer Mesh3Out {
    float mesh3_out[];
};
uniform int u_count;     // vertices
uniform int u_offset;    // first vertex of this dispatch

void main() {
    int k = u_offset + int(gl_GlobalInvocationID.x);
    if (k >= u_count) {
        return;
    }
    int at = 4 * k;
    vec4 r1 = TABLE_FETCH(mesh3_records, at + 1), r2 = TABLE_FETCH(mesh3_records, at + 2);
    vec4 r3 = TABLE_FETCH(mesh3_records, at + 3);
    mat3 rows = mesh3_rows(r1, r2, r3);
#if MESH3_GIVEN_NORMALS
    vec3 n = vec3(mesh3_normals[3 * k], mesh3_normals[3 * k + 1], mesh3_normals[3 * k + 2]);
#else
    vec3 n = vec3(mesh3_sums[(MESH3_SUMS * k + MESH3_SUM_AT) / 4].xyz);
#endif
    vec3 carried = mesh3_carried(mesh3_cofactor(rows), r3.w, n);
    mesh3_out[MESH3_RECORD * k] = carried.x;
    mesh3_out[MESH3_RECORD * k + 1] = carried.y;
    mesh3_out[MESH3_RECORD * k + 2] = carried.z;
}
