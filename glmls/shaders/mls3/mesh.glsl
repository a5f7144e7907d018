// What the passes over a 3D mesh share (glmls.engine.deform3): the layouts of their buffers,
// the cofactor, unit vectors and the faces.
//
// Vertices: scaled (mls3/points.comp.glsl's input), one vec4 each (w unused): one load each.
// A vertex's record (mls3/points.comp.glsl, MLS3_MESH), MESH3_RECORD floats, 4 vec4: 0..2
// f(v) - v (scaled), 3..11 J row by row (J[r][c] = d f_c / d v_r at 3 + 3 r + c), 12..14 the
// deformed unit normal, 15 det J. Where the normals come from the faces, the points pass
// leaves 12 and 13 the scale of the vertex's normal sum (its largest |component| and its
// faces, as floats) for the faces pass, and the normals pass writes the normal over them.
// A vertex's normal sums, MESH3_SUMS ints (2 ivec4): the largest |component| of the normals
// of the faces at it (float bits), how many faces it is in (mls3/mesh_scales.comp.glsl),
// 2 unused; then the sum of those normals in fixed point (mls3/mesh_folds.comp.glsl): each
// term rounded to 2^30 / (faces at it) units of that largest component, so that no sum
// overflows and every sum is exact, whatever the order the atomic additions take; 1 unused.
// Faces: 3 ints per face, vertex indices; the buffer holds a whole number of 4 faces (the
// passes over faces read 4 at a time, as 3 ivec4, and skip those past the last).
#define MESH3_RECORD 16
#define MESH3_SUMS 8
#define MESH3_SUM_AT 4
// faces per invocation of the passes over faces
#define MESH3_FACES 4

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

// the rows of J from a record's first 3 vec4
mat3 mesh3_rows(vec4 r0, vec4 r1, vec4 r2) {
    return mat3(vec3(r0.w, r1.xy), vec3(r1.zw, r2.x), r2.yzw);
}

#ifdef MESH3_FACE_PASS
layout(std430, binding = BIND_MESH_FACES) readonly buffer Mesh3Faces {
    ivec4 mesh3_faces[];
};
layout(std430, binding = BIND_POINTS) readonly buffer Mesh3Vertices {
    vec4 mesh3_vertices[];
};
uniform int u_count;     // faces
uniform int u_offset;    // first face of this dispatch

// The MESH3_FACES faces from ``first`` (a multiple of 4): 3 loads for their 12 indices.
void mesh3_faces_from(int first, out ivec3 corners[MESH3_FACES]) {
    int at = 3 * (first / 4);
    ivec4 a = mesh3_faces[at], b = mesh3_faces[at + 1], c = mesh3_faces[at + 2];
    corners[0] = a.xyz;
    corners[1] = ivec3(a.w, b.xy);
    corners[2] = ivec3(b.zw, c.x);
    corners[3] = c.yzw;
}
#endif
