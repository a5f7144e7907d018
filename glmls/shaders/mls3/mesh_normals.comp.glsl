// The deformed unit normals of a mesh's vertices from the sums of their faces' normals
// (mls3/mesh.glsl; mls3/mesh_folds.comp.glsl's MESH3_NORMAL_SUMS), one invocation per
// vertex: the sum's direction n carried by cof(J) with the sign of det J,
// n cof(J) sign(det J), over the scale in the vertex's record (12..14).
layout(local_size_x = LOCAL_SIZE) in;

#include "mls3/mesh.glsl"

layout(std430, binding = BIND_MESH_NORMALS) readonly buffer Mesh3Sums {
    ivec4 mesh3_sums[];
};
layout(std430, binding = BIND_DEFORMED) buffer Mesh3Records {
    vec4 mesh3_records[];
};
uniform int u_count;     // vertices
uniform int u_offset;    // first vertex of this dispatch

void main() {
    int k = u_offset + int(gl_GlobalInvocationID.x);
    if (k >= u_count) {
        return;
    }
    int at = 4 * k;
    mat3 rows = mesh3_rows(mesh3_records[at], mesh3_records[at + 1], mesh3_records[at + 2]);
    float det = mesh3_records[at + 3].w;
    vec3 n = mesh3_unit(vec3(mesh3_sums[(MESH3_SUMS * k + MESH3_SUM_AT) / 4].xyz));
    vec3 carried = mesh3_unit((mesh3_cofactor(rows) * n) * sign(det));
    mesh3_records[at + 3] = vec4(carried, det);
}
