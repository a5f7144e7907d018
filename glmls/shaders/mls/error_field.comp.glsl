// The MLS error field of "Extensions to the MLS method for image deformation", eq. (7):
//   E_MLS(v) = sum_i |l_v(p_i) - q_i|^2,   l_v(x) = x M_v + T_v,
// unweighted, so that configurations with different weights compare fairly. A segment handle
// adds the integral along it, per pixel of source length, of |l_v(p(t)) - q(t)|^2: the
// residual is linear in t, so that is L (|r_a|^2 + r_a . r_b + |r_b|^2) / 3 with r_a, r_b the
// residuals at its ends.
//
// l_v(p_i) - q_i is computed as (p_i - v) M + (f(v) - q_i): every term is a difference of
// nearby scaled coordinates, which float32 keeps to ~1e-7 of the image size (x M + T with
// |T| ~ |x| would cancel). The result is in scaled units; the host multiplies by scale^2.
//
// MLS_ERROR_INTERPOLATE 0: evaluate MLS on a lattice (mls/lattice.glsl: the pixel centres,
//                          or the corners of a coarse mesh) -> error_out[row * dims.x + col];
//                          with MLS_ERROR_POINTS, at the u_count points of a list instead
//                          (laid out u_dims.x per row) -> error_out[k];
//                       1: no MLS: bilinear interpolation of the values at the corners of a
//                          mesh every u_grid pixels (common/lattice.glsl) to the pixel
//                          centres of a W x H image.
layout(local_size_x = LOCAL_SIZE_2D, local_size_y = LOCAL_SIZE_2D) in;

#ifndef MLS_ERROR_POINTS
#define MLS_ERROR_POINTS 0
#endif

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
#if MLS_ERROR_POINTS
layout(std430, binding = BIND_POINTS) readonly buffer MLSErrorPoints {
    vec2 mls_error_points[];   // scaled coordinates
};
uniform int u_count;
#else
#include "mls/lattice.glsl"
#endif
#endif

#if !MLS_ERROR_INTERPOLATE
// Handle i's squared residual |p_i M + T - q_i|^2 at the point (r: f there), added to e. A
// residual below float32's resolution of its terms is rounding noise: it counts as 0, so
// that a deformation that fits every handle exactly (identity) gives E = 0.
void mls_error_add(inout float e, MLSResult r, vec2 v, int i, bool use) {
    vec4 h = mls_handle(i);
    vec2 dp = h.xy - v;
    vec2 res = vec2(dp.x * r.M.x + dp.y * r.M.z, dp.x * r.M.y + dp.y * r.M.w) + (r.f - h.zw);
    float res2 = dot(res, res);
    float floor = MLS_ERROR_FLOOR * (1.0 + length(dp));
    e += use && res2 > floor * floor ? res2 : 0.0;
}
#define MLS_ERROR_ADD(i, use) mls_error_add(e, r, v, i, use);
#endif

void main() {
    ivec2 ij = ivec2(gl_GlobalInvocationID.xy);
#if MLS_ERROR_INTERPOLATE
    if (ij.x >= u_dims.x || ij.y >= u_dims.y) {
        return;
    }
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
    // No early return past the end: those invocations evaluate the last point and store
    // nothing (as mls/points.comp.glsl: behind a return llvmpipe reads every handle lane by
    // lane).
#if MLS_ERROR_POINTS
    int k = ij.y * u_dims.x + ij.x;
    bool store = k < u_count;
    vec2 v = mls_error_points[clamp(k, 0, max(u_count - 1, 0))];
#else
    bool store = all(lessThan(ij, u_dims));
    vec2 v = mls_lattice_point(min(ij, u_dims - 1));
#endif
    MLSResult r = mls_eval(v);
    float e = 0.0;
    int n = mls_handle_count();
    MLS_BLOCKS(MLS_ERROR_ADD, n)
#if MLS_SEGMENTS
    for (int s = 0; s < u_segment_count; ++s) {
        vec4 src = mls_handle(u_segment_offset + 2 * s);
        vec4 dst = mls_handle(u_segment_offset + 2 * s + 1);
        vec2 da = src.xy - v;
        vec2 db = src.zw - v;
        vec2 ra = vec2(da.x * r.M.x + da.y * r.M.z, da.x * r.M.y + da.y * r.M.w) + (r.f - dst.xy);
        vec2 rb = vec2(db.x * r.M.x + db.y * r.M.z, db.x * r.M.y + db.y * r.M.w) + (r.f - dst.zw);
        float fa = MLS_ERROR_FLOOR * (1.0 + length(da));
        float fb = MLS_ERROR_FLOOR * (1.0 + length(db));
        if (dot(ra, ra) > fa * fa || dot(rb, rb) > fb * fb) {
            float L = length(src.zw - src.xy) * u_length_unit;
            e += L * (dot(ra, ra) + dot(ra, rb) + dot(rb, rb)) / 3.0;
        }
    }
#endif
    if (store) {
        error_out[ij.y * u_dims.x + ij.x] = e;
    }
#endif
}
