// The MLS error field of "Extensions to the MLS method for image deformation", eq. (7):
//   E_MLS(v) = sum_i |l_v(p_i) - q_i|^2,   l_v(x) = x M_v + T_v,
// unweighted, so that configurations with different weights compare fairly.
//
// l_v(p_i) - q_i is computed as (p_i - v) M + (f(v) - q_i): every term is a difference of
// nearby scaled coordinates, which float32 keeps to ~1e-7 of the image size (x M + T with
// |T| ~ |x| would cancel). The result is in scaled units; the host multiplies by scale^2.
//
// MLS_ERROR_INTERPOLATE 0: evaluate MLS on a lattice (mls/lattice.glsl: the pixel centres,
//                          or the corners of a coarse mesh) -> error_out[row * dims.x + col];
//                       1: no MLS: bilinear interpolation of the values at the corners of a
//                          mesh every u_grid pixels (common/lattice.glsl) to the pixel
//                          centres of a W x H image.
layout(local_size_x = LOCAL_SIZE_2D, local_size_y = LOCAL_SIZE_2D) in;

uniform ivec2 u_dims;   // output columns, rows

// Residuals shorter than this (scaled units, times 1 + |p_i - v|) count as 0: ~32 float32
// ulps of the scaled coordinates, i.e. 4e-6 * scale pixels (0.001 px on a 512 px image).
const float MLS_ERROR_FLOOR = 4.0e-6;

layout(std430, binding = BIND_ERROR_FIELD) writeonly buffer MLSErrorOut {
    float error_out[];
};

#if MLS_ERROR_INTERPOLATE
#include "common/lattice.glsl"
layout(std430, binding = BIND_ERROR_VERTICES) readonly buffer MLSErrorVertices {
    float error_vertex[];
};
uniform ivec2 u_vertex_dims;   // vertices per row, rows

// Cell index and weight of pixel centre c (integer) along one axis of n pixels.
void mls_error_cell(int c, int n, int vertices, out int k, out float t) {
    k = min((2 * c + 1) / (2 * u_grid), vertices - 2);
    float x0 = lattice_corner(k, n);
    float x1 = lattice_corner(k + 1, n);
    t = (float(c) - x0) / (x1 - x0);
}
#else
#include "mls/visit.glsl"
#include "mls/lattice.glsl"
#endif

void main() {
    ivec2 ij = ivec2(gl_GlobalInvocationID.xy);
    if (ij.x >= u_dims.x || ij.y >= u_dims.y) {
        return;
    }
#if MLS_ERROR_INTERPOLATE
    int kx, ky;
    float tx, ty;
    mls_error_cell(ij.x, u_dims.x, u_vertex_dims.x, kx, tx);
    mls_error_cell(ij.y, u_dims.y, u_vertex_dims.y, ky, ty);
    int i00 = ky * u_vertex_dims.x + kx;
    int i10 = i00 + u_vertex_dims.x;
    float top = mix(error_vertex[i00], error_vertex[i00 + 1], tx);
    float bottom = mix(error_vertex[i10], error_vertex[i10 + 1], tx);
    error_out[ij.y * u_dims.x + ij.x] = mix(top, bottom, ty);
#else
    vec2 v = mls_lattice_point(ij);
    MLSResult r = mls_eval(v);
    float e = 0.0;
    int n = mls_handle_count();
    for (int i = 0; i < n; ++i) {
        vec4 h = mls_handle(i);
        vec2 dp = h.xy - v;
        vec2 res = vec2(dp.x * r.M.x + dp.y * r.M.z, dp.x * r.M.y + dp.y * r.M.w) + (r.f - h.zw);
        float res2 = dot(res, res);
        // A residual below float32's resolution of its terms is rounding noise: count it as
        // 0, so that a deformation that fits every handle exactly (identity) gives E = 0.
        float floor = MLS_ERROR_FLOOR * (1.0 + length(dp));
        if (res2 > floor * floor) {
            e += res2;
        }
    }
    error_out[ij.y * u_dims.x + ij.x] = e;
#endif
}
