// Evaluates the 3D f at a list of points, or (MLS3_LATTICE) at the points of a regular
// lattice: point (i, j, k) is u_lattice3_origin + (i, j, k) * u_lattice3_step (scaled), item
// index i + nx (j + ny k), and this run writes items u_first .. u_first + u_count - 1 from
// output index 0. Outputs, tightly packed float32 (std430 float arrays):
//   a list: f(v) - v (scaled, of the targets less u_mls3_offset; the caller adds v and the
//     offset in float64), 3 floats per point;
//   a lattice: f(v) in voxels, 3 floats per point;
//   MLS3_WRITE_MATRIX: M row by row (the mathematical M[i][j] at 9 i + 3 r + c), 9 floats;
//   MLS3_WRITE_JACOBIAN: J = df/dv (mls3_eval_jacobian: the solve's derivative, or central
//     differences of step mls3_jacobian_step(v), scaled, where v snaps to a handle),
//     J[r][c] = d f_c / d v_r (row vectors: df = dv J), 9 floats;
//   MLS3_MESH (a mesh's vertices, mls3/mesh.glsl's table, with MLS3_WRITE_JACOBIAN): one
//     record of MESH3_RECORD floats per mesh vertex instead (mls3/mesh.glsl): the deformed
//     unit normal n cof(J) sign(det J) of the vertex's normal (MLS3_MESH_NORMALS: 0 none,
//     1 the mesh's own, 3 floats per vertex; 2 later: the vertex, for the passes over
//     faces, mls3/mesh_normals.comp.glsl writing the normal over it), f - v, J, det J.
//   MLS3_MESH_FLAT (a mesh, affine with every target on one plane): one uint per vertex, 1
//     where J is the derivative of affine's plain solve, or took that solve at each of its
//     probes (mls3_jacobian_plain: f maps them into the plane, and det J is 0 but for
//     float32's rounding), else 0.
// J: mls3_eval_jacobian (mls3/core.glsl), f and J sharing the passes over the handles.
// MLS3_STAGE 1 and 2 are two passes (glmls.gl.dispatch.SecondPass): the first takes only the
// solve's plain branch (MLS3_SOLVE_LATER) and J's shared passes (MLS3_JACOBIAN_LATER) and
// lists the points that need more, the solve's other branches or mls3_jacobian's full
// evaluations; the second computes those points again with everything, one invocation per
// listed point. 0 does it all in one pass.
#ifndef MLS3_STAGE
#define MLS3_STAGE 0
#endif
#if MLS3_STAGE == 1
#define MLS3_JACOBIAN_LATER 1
#ifndef MLS3_SOLVE_LATER
#define MLS3_SOLVE_LATER 1
#endif
#endif
layout(local_size_x = LOCAL_SIZE) in;

#include "mls3/core.glsl"
#include "common/loops.glsl"
#include "mls3/mesh.glsl"
#include "mls3/jacobian_step.glsl"

#if MLS3_LATTICE
uniform vec3 u_lattice3_origin;
uniform vec3 u_lattice3_step;
uniform ivec3 u_lattice3_dims;
uniform int u_first;
#elif MLS3_MESH
// the vertices: mls3/mesh.glsl's table
#else
layout(std430, binding = BIND_POINTS) readonly buffer MLS3Points {
    float mls3_points[];
};
#endif
uniform int u_count;     // items of this run
uniform int u_offset;    // first index of this dispatch (dispatches are capped in size)

#if MLS3_MESH
layout(std430, binding = BIND_DEFORMED) writeonly buffer MLS3OutRecords {
    vec4 mls3_out_records[];
};
#else
layout(std430, binding = BIND_DEFORMED) writeonly buffer MLS3OutF {
    float mls3_out_f[];
};
#endif
#if (MLS3_WRITE_MATRIX || MLS3_WRITE_JACOBIAN) && !MLS3_MESH
layout(std430, binding = BIND_MATRICES) writeonly buffer MLS3OutM {
    float mls3_out_m[];
};
#endif
#ifndef MLS3_MESH_FLAT
#define MLS3_MESH_FLAT 0
#endif
#if MLS3_MESH && MLS3_MESH_FLAT
layout(std430, binding = BIND_MESH_FLAT) writeonly buffer MLS3OutFlat {
    uint mls3_out_flat[];
};
#endif
#if MLS3_MESH && MLS3_MESH_NORMALS == 1
layout(std430, binding = BIND_MESH_NORMALS) readonly buffer MLS3Normals {
    float mls3_normals[];
};
#endif

vec3 mls3_item_point(int i) {
#if MLS3_LATTICE
    int index = u_first + i;
    int nx = u_lattice3_dims.x, ny = u_lattice3_dims.y;
    ivec3 ijk = ivec3(index % nx, (index / nx) % ny, index / (nx * ny));
    return u_lattice3_origin + vec3(ijk) * u_lattice3_step;
#elif MLS3_MESH
    return mesh3_vertex(i);
#else
    return vec3(mls3_points[3 * i], mls3_points[3 * i + 1], mls3_points[3 * i + 2]);
#endif
}

void mls3_store_matrix(int i, mat3 M) {
#if (MLS3_WRITE_MATRIX || MLS3_WRITE_JACOBIAN) && !MLS3_MESH
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
            mls3_out_m[9 * i + 3 * r + c] = M[c][r];
        }
    }
#endif
}

#if MLS3_MESH
// the vertex's own normal (any length; zero where it has none)
vec3 mls3_vertex_normal(int i) {
#if MLS3_MESH_NORMALS == 1
    return vec3(mls3_normals[3 * i], mls3_normals[3 * i + 1], mls3_normals[3 * i + 2]);
#else
    return vec3(0.0);
#endif
}

void mls3_store_record(int i, vec3 v, vec3 d, mat3 J) {
    // the rows of J (the GLSL J's columns are the mathematical J's columns)
    mat3 rows = transpose(J);
    mat3 cof = mesh3_cofactor(rows);
    float det = dot(rows[0], cof[0]);
#if MLS3_MESH_NORMALS == 2
    vec3 first = v;
#else
    vec3 first = mesh3_carried(cof, det, mls3_vertex_normal(i));
#endif
    int at = 4 * i;
    mls3_out_records[at] = vec4(first, d.x);
    mls3_out_records[at + 1] = vec4(d.yz, rows[0].xy);
    mls3_out_records[at + 2] = vec4(rows[0].z, rows[1]);
    mls3_out_records[at + 3] = vec4(rows[2], det);
#if MLS3_MESH_FLAT
    mls3_out_flat[i] = mls3_jacobian_plain ? 1u : 0u;
#endif
}
#endif

#if MLS3_STAGE
// The points the first stage left to the second.
#define SECOND_PASS_ITEM uint
#include "common/second_pass.glsl"
#endif

// f (and J) at item i of this run, stored where ``store``.
void mls3_item(int i, bool store) {
    vec3 v = mls3_item_point(i);
#if MLS3_WRITE_JACOBIAN
    mat3 J;
    MLS3Result r = mls3_eval_jacobian(v, mls3_jacobian_step(v), J);
#else
    MLS3Result r = mls3_eval(v);
#endif
    // past a CPU renderer's cap on loop iterations f left handles out: NaN, which the host
    // reports (glmls.engine.loops)
    r.d = loops_whole(2 + min(u_mls3_count, 0)) ? r.d : vec3(uintBitsToFloat(0x7fc00000u));
#if MLS3_STAGE == 1
    if (store && (mls3_jacobian_later || mls3_solve_later)) {
        second_pass_items[second_pass_slot()] = uint(i);   // room for every point
    }
#endif
    if (store) {
#if MLS3_MESH
        mls3_store_record(i, v, r.d, J);
#else
#if MLS3_LATTICE
        vec3 f = v * u_mls3_scale + u_mls3_center + (r.d * u_mls3_scale + u_mls3_offset);
#else
        vec3 f = r.d;
#endif
        mls3_out_f[3 * i] = f.x;
        mls3_out_f[3 * i + 1] = f.y;
        mls3_out_f[3 * i + 2] = f.z;
#if MLS3_WRITE_JACOBIAN
        mls3_store_matrix(i, J);
#elif MLS3_WRITE_MATRIX
        mls3_store_matrix(i, r.M);
#endif
#endif
    }
}

#if MLS3_STAGE == 2
void main() {
    // every listed point, however many the dispatch's work groups (at most u_max_groups)
    for (uint k = gl_GlobalInvocationID.x; k < second_pass_listed(); k += second_pass_stride()) {
        mls3_item(int(second_pass_items[k]), true);
    }
}
#else
void main() {
    // No early return for the items past the end: they evaluate the last point and store
    // nothing (see mls/points.comp.glsl: uniform handle loads need every lane active).
    int i = u_offset + int(gl_GlobalInvocationID.x);
    mls3_item(min(i, max(u_count - 1, 0)), i < u_count);
}
#endif
