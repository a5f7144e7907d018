// The points of a glmls.core.mesh.MeshLattice in scaled coordinates: point (i, j) is
// min(origin + (i, j) step, last), so that the last row and column land exactly on the image
// border and a point shared by two bands of rows is computed from the same integers.
#ifndef MLS_BATCH
#define MLS_BATCH 0   // 1: a batch's passes (mls/batch.glsl)
#endif
#if !MLS_BATCH  // a batch's passes set these per image (mls/batch.glsl)
uniform vec2 u_lattice_origin;
uniform vec2 u_lattice_step;
uniform vec2 u_lattice_last;
#endif
uniform ivec2 u_lattice_dims;   // points per row, rows (of the whole lattice)

vec2 mls_lattice_point(ivec2 ij) {
    return min(u_lattice_origin + vec2(ij) * u_lattice_step, u_lattice_last);
}
