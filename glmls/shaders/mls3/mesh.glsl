// What the passes over a 3D mesh share (glmls.engine.deform3): the layouts of their buffers
// and tables, the cofactor, unit vectors and the faces.
//
// The passes over faces read at random (a face's corners anywhere in the mesh), so what
// they read is in tables (glmls.gl.tables, common/table.glsl): a texel fetch gathers a
// texel for every lane where llvmpipe loads a storage buffer lane by lane and component by
// component, and a face's corner is one record, one cache line, with nothing else to read.
// Vertices: scaled (mls3/points.comp.glsl's input), a table of one vec4 each (w unused).
// A vertex's record (mls3/points.comp.glsl, MLS3_MESH), MESH3_RECORD floats, 4 vec4: 0..2
// the deformed unit normal, 3..5 f(v) - v (scaled), 6..14 J row by row (J[r][c] =
// d f_c / d v_r at 6 + 3 r + c), 15 det J. In a mesh with faces, 0..2 are first the vertex
// v (scaled, as the vertices' table holds it): the records are copied into a table of 4
// texels per vertex for the faces pass, a corner being one record, and the normals pass
// (mls3/mesh_normals.comp.glsl) writes the normal over v in the buffer.
// A vertex's normal sums, MESH3_SUMS ints (2 ivec4): the largest |component| of the normals
// of the faces at it (float bits), how many faces it is in (mls3/mesh_scales.comp.glsl),
// 2 unused; then the sum of those normals in fixed point (mls3/mesh_folds.comp.glsl): each
// term rounded to 2^30 / (faces at it) units of that largest component, so that no sum
// overflows and every sum is exact, whatever the order the atomic additions take; 1 unused.
// Faces: 3 ints per face, vertex indices, a table of uvec4 holding a whole number of 4
// faces (the passes over faces read 4 at a time, as 3 uvec4, and skip those past the last).
#define MESH3_RECORD 16
#define MESH3_SUMS 8
#define MESH3_SUM_AT 4
// faces per invocation of the passes over faces
#define MESH3_FACES 4

#include "common/table.glsl"

layout(binding = BIND_MESH_VERTICES) uniform sampler2D mesh3_vertices;
layout(binding = BIND_MESH_RECORDS) uniform sampler2D mesh3_records;

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

// The deformed unit normal n cof(J) sign(det J) of a vertex's normal n (any length, zero
// for none): sum_r n_r cof's row r.
vec3 mesh3_carried(mat3 cof, float det, vec3 n) {
    return mesh3_unit((cof * mesh3_unit(n)) * sign(det));
}

vec3 mesh3_vertex(int k) {
    return TABLE_FETCH(mesh3_vertices, k).xyz;
}

// the rows of J from a record's last 3 vec4
mat3 mesh3_rows(vec4 r1, vec4 r2, vec4 r3) {
    return mat3(vec3(r1.zw, r2.x), r2.yzw, r3.xyz);
}

#ifdef MESH3_FACE_PASS
layout(binding = BIND_MESH_FACES) uniform usampler2D mesh3_faces;
uniform int u_count;     // faces
uniform int u_offset;    // first face of this dispatch

// The MESH3_FACES faces from ``first`` (a multiple of 4): 3 fetches for their 12 indices.
void mesh3_faces_from(int first, out ivec3 corners[MESH3_FACES]) {
    int at = 3 * (first / 4);
    ivec4 a = ivec4(TABLE_FETCH(mesh3_faces, at));
    ivec4 b = ivec4(TABLE_FETCH(mesh3_faces, at + 1));
    ivec4 c = ivec4(TABLE_FETCH(mesh3_faces, at + 2));
    corners[0] = a.xyz;
    corners[1] = ivec3(a.w, b.xy);
    corners[2] = ivec3(b.zw, c.x);
    corners[3] = c.yzw;
}
#endif
