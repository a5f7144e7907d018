// What the passes over a 3D mesh share (glmls.engine.deform3): the layouts of their buffers,
// the cofactor and unit vectors.
//
// A vertex's record (mls3/points.comp.glsl, MLS3_MESH), MESH3_RECORD floats: 0..2 f(v) - v
// (scaled), 3..11 J row by row (J[r][c] = d f_c / d v_r at 3 + 3 r + c), 12..14 the deformed
// unit normal, 15 det J.
// A vertex's normal sums (mls3/mesh_normals.comp.glsl), MESH3_SUMS ints: the largest
// |component| of the normals of the faces at it (float bits), how many faces it is in, then
// the sum of those normals in fixed point: each term rounded to 2^30 / (faces at it) units
// of that largest component, so that no sum overflows and every sum is exact, whatever the
// order the atomic additions take.
// Faces: 3 ints per face, vertex indices.
#define MESH3_RECORD 16
#define MESH3_SUMS 5

// det(J) J^-T for J given by its rows (rows[r] the mathematical row r), returned the same
// way: its rows are cross products of J's rows (defined, and continuous, for singular J too).
mat3 mesh3_cofactor(mat3 rows) {
    return mat3(cross(rows[1], rows[2]), cross(rows[2], rows[0]), cross(rows[0], rows[1]));
}

// v / |v|, zero for a zero v (scaled first: no square underflows or overflows)
vec3 mesh3_unit(vec3 v) {
    float largest = max(max(abs(v.x), abs(v.y)), abs(v.z));
    if (!(largest > 0.0)) {
        return vec3(0.0);
    }
    vec3 s = v / largest;
    return s / length(s);
}

layout(std430, binding = BIND_MESH_FACES) readonly buffer Mesh3Faces {
    int mesh3_faces[];
};

ivec3 mesh3_face(int face) {
    return ivec3(mesh3_faces[3 * face], mesh3_faces[3 * face + 1], mesh3_faces[3 * face + 2]);
}
