// Moving Least Squares in three dimensions: f(v) = v M + T at a point v = (x, y, z) =
// (column, row, slice), with the weights of mls/weights.glsl and the transforms of
// mls3/solve.glsl. The one include of every pass over a 3D f (glmls.engine.kernel3):
//
//   MLS3Result mls3_eval(vec3 v)            f, f - v and M at v (scaled coordinates)
//   vec3 mls3_f(vec3 v)                     f(v), scaled coordinates
//   void mls3(vec3 v, out mat3 M, out vec3 T)   f(v) = v * M + T, scaled coordinates
//   vec3 mls3_to_scaled(vec3 voxel), vec3 mls3_to_voxels(vec3 scaled)
//   vec3 mls3_f_voxels(vec3 voxel)          f in voxel coordinates
//   mat3 mls3_jacobian(vec3 v, float h)     df/dv by central differences of step h (scaled)
//   MLS3Result mls3_eval_jacobian(vec3 v, float h, out mat3 J)   f, and J as the closed
//                                           form's derivative (one pass over the handles
//                                           per axis), or mls3_jacobian's differences
//   mls3_stencil_*                          the same differences, for a pass's own loop
//
// Scaled coordinates: (voxel - u_mls3_center) / u_mls3_scale (MLSKernel3.scaling), so that
// float32 keeps ~1e-7 of the volume's extent. M is a GLSL mat3 used as ``v * M`` (row
// vectors, the paper's convention): the mathematical M[i][j] is the GLSL M[j][i].
//
// Handles: two rows of the handle storage (mls/handles.glsl) each, (p, 0) then (e, 0) with
// e = q - t - p, scaled; u_mls3_count of them. t = u_mls3_offset (voxels, MLSKernel3.offset)
// takes far targets' common translation out of float32: f and d here are those of the
// targets q - t, and f in voxels is v + d * scale + t (exact for MLS, which moves with its
// targets). Defines (MLSKernel3.defines): those of
// mls/weighting.glsl, MLS_TRANSFORM, MLS_STORAGE (and its own), MLS3_UNROLL (0, 16 or 64:
// at most that many handles, read at constant indices, the slots past u_mls3_count zeros).

#include "mls/handles.glsl"
#include "mls/weighting.glsl"
#include "mls3/solve.glsl"

uniform int u_mls3_count;        // handles
uniform vec3 u_mls3_center;      // scaled = (voxel - center) / scale
uniform float u_mls3_scale;
uniform vec3 u_mls3_offset;      // voxels: f = v + d * scale + offset

struct MLS3Result {
    vec3 f;   // f(v), scaled
    vec3 d;   // f(v) - v, exactly 0 where every handle in reach stays (q = p)
    mat3 M;   // the linear part, v * M
};

vec3 mls3_p(int i) {
    return mls_handle(2 * i).xyz;
}

vec3 mls3_e(int i) {
    return mls_handle(2 * i + 1).xyz;
}

vec3 mls3_to_scaled(vec3 voxel) {
    return (voxel - u_mls3_center) / u_mls3_scale;
}

vec3 mls3_to_voxels(vec3 scaled) {
    return scaled * u_mls3_scale + u_mls3_center;
}

// One evaluation: the nearest handle (for snapping, the weights' normalisation and the
// moments' origin), then one pass accumulating every weighted moment about the nearest
// handle o (P = p - p_o, E = e - e_o; see mls/core.glsl for why about o), then the solve.
struct MLS3Accum {
    vec3 v;
    bool hit;       // v snaps to handle o: f(v) = its q
    vec3 op;        // the nearest handle's p and e
    vec3 oe;
    float m;        // normalisation distance (mls/weights.glsl)
    float g;        // the weights' offset: m, or the gaussian's (mls_gaussian_offset)
#if MLS_REACH_GAUSSIAN
    float g_o;      // g - |v - p_o|^2 (mls3_weight_at)
    vec3 twice_u;   // 2 (v - p_o)
#endif
    float inv_m;
    float sigma;
    float W;        // sum w
    vec3 P;         // sum w P
    vec3 E;         // sum w E
    vec3 Ad;        // sum w P P^T: diagonal
    vec3 Ao;        // ... and (01, 02, 12)
    mat3 D;         // sum w P^T E
    MLSYardstick yard;   // for "coincident" sources (mls/weighting.glsl, mls3_solve)
#if MLS_WEIGHT_NEXT
    float near2;    // the least squared distance a weight sees (mls/core.glsl, mls_begin)
#endif
};

// With the gaussian it tracks the least squared distance above the nearest's too (d2next,
// see mls_gaussian_offset), and that handle's index (next, for mls3_begin's offset).
void mls3_nearest(inout float d2min, inout float d2next, inout int nearest, inout int next,
                  vec3 v, int i, bool use) {
    vec3 dp = mls3_p(i) - v;
    float d2 = use ? dot(dp, dp) : 3.0e38;
#if MLS_REACH_GAUSSIAN
    next = d2 < d2min ? nearest : (d2 > d2min && d2 < d2next ? i : next);
#endif
    nearest = d2 < d2min ? i : nearest;
    mls_track_next(d2next, d2min, d2);
    d2min = min(d2min, d2);
}

void mls3_far(inout float d2far, vec3 v, int i, bool use) {
    vec3 dp = mls3_p(i) - v;
    float d2 = use ? dot(dp, dp) : 3.0e38;
    d2far = min(d2far, d2 > u_hit2 ? d2 : 3.0e38);
}
#define MLS3_FAR(i, use) mls3_far(d2far, v, i, use);

MLS3Accum mls3_begin(vec3 v, float d2min, float d2next, int nearest, int next, int n) {
    MLS3Accum a;
    a.v = v;
    a.hit = u_snap && d2min <= u_hit2;
    a.op = n > 0 ? mls3_p(nearest) : vec3(0.0);
    a.oe = n > 0 ? mls3_e(nearest) : vec3(0.0);
    float d2far = 3.0e38;
    if (a.hit) {
        // the normalisation distance of a snapped point: the nearest beyond the snapping
        // distance (a loop: lanes rarely take it)
        MLS_BLOCKS(MLS3_FAR, n)
    }
    a.m = mls_normalisation(a.hit ? d2far : max(d2min, u_hit2));
    a.inv_m = 1.0 / a.m;
    a.sigma = mls_sigma(a.m);
#if MLS_WEIGHT_NEXT
    // the weights relative to the nearest handles apart from the nearest one's place (see
    // mls/core.glsl, mls_begin); m stays the nearest's, which bounds the probes' distances
    // (mls3_eval_jacobian)
    a.near2 = 0.0;
    if (!a.hit && d2next < 3.0e38) {
        float next = max(a.m, d2next);
        a.inv_m = 1.0 / next;
        a.sigma = mls_sigma(next);
        a.near2 = next * exp2(-MLS_NEAR_BITS / u_alpha);
    }
#endif
#if MLS_REACH_GAUSSIAN
    a.g = mls_gaussian_offset(a.m, d2next);
#else
    a.g = a.m;
#endif
#if MLS_REACH_GAUSSIAN
    vec3 u = v - a.op;
    a.twice_u = 2.0 * u;
    // the nearest apart's excess about the nearest, as mls3_excess takes each handle's
    // (mls/core.glsl's mls_begin: g - |u|^2 loses more than R^2 far out)
    vec3 P_next = (n > 0 ? mls3_p(next) : vec3(0.0)) - a.op;
    bool apart = d2next < 3.0e38 && a.g == d2next;
    a.g_o = apart ? dot(P_next, P_next - a.twice_u) : (a.g == d2min ? 0.0 : a.g - dot(u, u));
    a.g_o = max(a.g_o, 0.0);   // g >= |u|^2 (mls/core.glsl's mls_begin)
#endif
    a.W = 0.0;
    a.P = vec3(0.0);
    a.E = vec3(0.0);
    a.Ad = vec3(0.0);
    a.Ao = vec3(0.0);
    a.D = mat3(0.0);
    a.yard = mls_yardstick_begin();
    return a;
}

// Adds one handle of weight w, P = p - p_o, E = e - e_o and squared distance d2.
void mls3_add(inout MLS3Accum a, float w, vec3 P, vec3 E, float d2) {
    vec3 wP = w * P;
    a.W += w;
    a.P += wP;
    a.E += w * E;
    a.Ad += wP * P;
    a.Ao += wP.xxy * P.yzz;
    a.D += outerProduct(wP, E);
    // the handles at the nearest one's place (P = 0) apart
    mls_yardstick_add(a.yard, P != vec3(0.0), w, d2);
}

// The squared distance d2 of a handle as its weight sees it (at least MLS_WEIGHT_NEXT's
// near2), and whether it gets no weight: an empty slot, and the snapped handle (and
// duplicates of it: their weight is infinite and their p^ zero)
float mls3_seen(MLS3Accum a, float d2, bool use, out bool none) {
    none = !use || (u_snap && d2 <= u_hit2);
#if MLS_WEIGHT_NEXT
    return max(d2, a.near2);
#else
    return d2;
#endif
}

#if MLS_REACH_GAUSSIAN
// d2 - g of the handle at p about the nearest handle, as mls/core.glsl's mls_handle_weight
// takes it
float mls3_excess(MLS3Accum a, vec3 p) {
    vec3 P = p - a.op;
    vec3 Q = P - a.twice_u;
    return mls_excess(dot(P, Q), dot(abs(P), abs(P) + abs(a.twice_u)), a.g_o);
}
#endif

// The weight of handle i at p (its squared distance to v in d2)
float mls3_weight_at(MLS3Accum a, vec3 p, bool use, out float d2) {
    vec3 dp = p - a.v;
    d2 = dot(dp, dp);
    bool none;
    float seen = mls3_seen(a, d2, use, none);
#ifdef MLS_WEIGHT_FUNCTION64
    if (!none && mls_at_edge(d2)) {
        // near d = R: d2 exact in float64 (of float32 p and v), and the weight from it
        dvec3 dp64 = dvec3(p) - dvec3(a.v);
        return mls_weight_edge(dot(dp64, dp64), a.g, a.inv_m, a.sigma, seen);
    }
#endif
#if MLS_REACH_GAUSSIAN
    float w = mls_weight_excess(mls3_excess(a, p), seen, a.inv_m);
#else
    float w = mls_weight_seen(d2, seen, a.g, a.inv_m, a.sigma);
#endif
    return none ? 0.0 : w;
}

void mls3_accumulate(inout MLS3Accum a, int i, bool use) {
    vec3 p = mls3_p(i);
    float d2;
    float w = mls3_weight_at(a, p, use, d2);
    mls3_add(a, w, p - a.op, mls3_e(i) - a.oe, d2);
}

#if !MLS3_SOLVE_LATER
#include "mls3/solve_full.glsl"

// The handles of an iteration of the float64 moments' loop: 4 or 16 (mls3_finish_full).
#ifndef MLS3_FULL_BLOCK
#define MLS3_FULL_BLOCK 4
#elif MLS3_FULL_BLOCK != 4 && MLS3_FULL_BLOCK != 16
#error "MLS3_FULL_BLOCK: 4 or 16"
#endif

// The moments of mls3_add in float64, for the points that mls3_solve leaves (mls3/solve_full.glsl
// says why): the same float32 weights, and the handles' differences, exact in float64.
struct MLS3Sums64 {
    double W;
    dvec3 P;
    dvec3 E;
    dvec3 Ad;
    dvec3 Ao;
    dmat3 D;
};

void mls3_accumulate_full(inout MLS3Sums64 s, MLS3Accum a, int i, bool use) {
    vec3 p = mls3_p(i);
    float d2;
    double w = double(mls3_weight_at(a, p, use, d2));
    dvec3 P = dvec3(p) - dvec3(a.op);
    dvec3 E = dvec3(mls3_e(i)) - dvec3(a.oe);
    dvec3 wP = w * P;
    s.W += w;
    s.P += wP;
    s.E += w * E;
    s.Ad += wP * P;
    s.Ao += wP.xxy * P.yzz;
    s.D += outerProduct(wP, E);
}
#define MLS3_ACC_FULL(i, use) mls3_accumulate_full(s, a, i, use);

// a's moments summed again in float64 (mls3_accumulate_full)
MLS3Sums64 mls3_sums64(MLS3Accum a) {
    int n = u_mls3_count;
    MLS3Sums64 s;
    s.W = 0.0lf;
    s.P = dvec3(0.0lf);
    s.E = dvec3(0.0lf);
    s.Ad = dvec3(0.0lf);
    s.Ao = dvec3(0.0lf);
    s.D = dmat3(0.0lf);
    // A loop whatever MLS3_UNROLL (only the points the solve left run it), of
    // MLS3_FULL_BLOCK handles an iteration, in the same order either way: four by default,
    // as sixteen (MLS_BLOCKS) take llvmpipe seconds more to compile in float64 at every
    // evaluation of f a program inlines; sixteen where a program inlines one evaluation and
    // makes many (mls3/newton.glsl), so that fewer of llvmpipe's loop iterations go to it.
#if MLS3_FULL_BLOCK == 16
    for (int mls_block = 0; mls_block < n; mls_block += 16) {
        MLS_BLOCK16(MLS3_ACC_FULL, mls_block, n)
    }
#else
    for (int mls_block = 0; mls_block < n; mls_block += 4) {
        MLS_BLOCK4(MLS3_ACC_FULL, mls_block, n)
    }
#endif
    return s;
}

// s's moments about p* = p_o + dp and e* = e_o + de (mls3_centred's, in float64)
void mls3_centred64(inout MLS3Sums64 s, out dvec3 dp, out dvec3 de) {
    dp = s.P / s.W;
    de = s.E / s.W;
    s.Ad -= s.P * dp;
    s.Ao -= s.P.xxy * dp.yzz;
    s.D -= outerProduct(s.P, de);
}

// The last mls3_finish_full's centred float64 moments, their centre (p* - p_o, e* - e_o)
// and N, where v did not snap (mls3_full_kept; mls3_finish clears it): mls3_ridge_rows
// differentiates the solve from there rather than summing and solving again.
bool mls3_full_kept = false;
MLS3Sums64 mls3_full_sums;
dvec3 mls3_full_dp;
dvec3 mls3_full_de;
dmat3 mls3_full_N;

// f at a point that mls3_solve left: its moments summed again in float64 and every rule of
// the solve (mls3_solve_full)
MLS3Result mls3_finish_full(MLS3Accum a) {
    MLS3Sums64 s = mls3_sums64(a);
    dvec3 pst = dvec3(a.op);
    dvec3 est = dvec3(a.oe);
    dvec3 dp = dvec3(0.0lf), de = dvec3(0.0lf);
    if (!a.hit) {
        mls3_centred64(s, dp, de);
        pst += dp;
        est += de;
    }
    dmat3 N = mls3_solve_full(s.Ad, s.Ao, s.D, double(mls_yardstick(a.yard)));
    mls3_full_kept = !a.hit;
    mls3_full_sums = s;
    mls3_full_dp = dp;
    mls3_full_de = de;
    mls3_full_N = N;
    MLS3Result r;
    r.d = vec3(est + (dvec3(a.v) - pst) * N);
    r.f = a.v + r.d;
    r.M = mat3(N + dmat3(1.0lf));
    return r;
}
#endif

MLS3Result mls3_identity(vec3 v) {
    MLS3Result r;
    r.f = v;
    r.d = vec3(0.0);
    r.M = mat3(1.0);
    return r;
}

// The moments about p* = p_o + P / W and e* = e_o + E / W: dp = p* - p_o, de = e* - e_o,
// A's diagonal ad and off-diagonal ao, and D
void mls3_centred(MLS3Accum a, out vec3 dp, out vec3 de, out vec3 ad, out vec3 ao,
                  out mat3 D) {
    dp = a.P / a.W;
    de = a.E / a.W;
    ad = a.Ad - a.P * dp;
    ao = a.Ao - a.P.xxy * dp.yzz;
    D = a.D - outerProduct(a.P, de);
}

MLS3Result mls3_finish(MLS3Accum a) {
    mls3_solve_plain = false;
    mls3_solve_polar = mat3(0.0);
#if !MLS3_SOLVE_LATER
    mls3_full_kept = false;
#endif
    if (!a.hit && !(a.W > 0.0)) {
        return mls3_identity(a.v);   // no handle reaches v (or there are none)
    }
    vec3 pst = a.op;
    vec3 est = a.oe;
    if (!a.hit) {
        // p* = p_o + sum w P / W, e* likewise, and the moments about them
        vec3 dp, de;
        mls3_centred(a, dp, de, a.Ad, a.Ao, a.D);
        pst += dp;
        est += de;
    }
    // snapped: p* = p_o and q* = q_o exactly, and the moments about them are the sums
    mat3 N = mls3_solve(a.Ad, a.Ao, a.D, mls_yardstick(a.yard));
#if !MLS3_SOLVE_LATER
    if (mls3_solve_later) {
        mls3_solve_later = false;
        return mls3_finish_full(a);
    }
#endif
    MLS3Result r;
    // f(v) = q* + (v - p*) M = v + e* + (v - p*) N
    r.d = est + (a.v - pst) * N;
    r.f = a.v + r.d;
    r.M = N + mat3(1.0);
    return r;
}

// MLS3_EACH(F): F(i, use) for every handle i (n = u_mls3_count), unrolled at constant
// indices where MLS3_UNROLL is 16 or 64 (llvmpipe then loads a handle once for all lanes),
// else a loop of blocks (mls/handles.glsl's MLS_BLOCKS: llvmpipe's limit on loop iterations).
#define MLS3_SLOT(F, i) F(i, (i) < n)
#define MLS3_R4(F, i) MLS3_SLOT(F, i) MLS3_SLOT(F, i + 1) MLS3_SLOT(F, i + 2) MLS3_SLOT(F, i + 3)
#define MLS3_R16(F, i) MLS3_R4(F, i) MLS3_R4(F, i + 4) MLS3_R4(F, i + 8) MLS3_R4(F, i + 12)
#define MLS3_R64(F, i) MLS3_R16(F, i) MLS3_R16(F, i + 16) MLS3_R16(F, i + 32) MLS3_R16(F, i + 48)
#if MLS3_UNROLL == 16
#define MLS3_EACH(F) MLS3_R16(F, 0)
#elif MLS3_UNROLL == 64
#define MLS3_EACH(F) MLS3_R64(F, 0)
#elif MLS3_UNROLL
#error "MLS3_UNROLL: 0, 16 or 64"
#else
#define MLS3_EACH(F) MLS_BLOCKS(F, n)
#endif
#define MLS3_NEAR(i, use) mls3_nearest(d2min, d2next, nearest, next, v, i, use);
#define MLS3_ACC(i, use) mls3_accumulate(a, i, use);

MLS3Result mls3_eval(vec3 v) {
    int n = u_mls3_count;
    float d2min = 3.0e38;
    float d2next = 3.0e38;
    int nearest = 0;
    int next = 0;
    MLS3_EACH(MLS3_NEAR)
    MLS3Accum a = mls3_begin(v, d2min, d2next, nearest, next, n);
    MLS3_EACH(MLS3_ACC)
    return mls3_finish(a);
}

// J = df/dv by central differences of step h (scaled), for row vectors: df = dv * J, the
// mathematical J[r][c] = d f_c / d v_r (the GLSL J[c][r]). The stencil's points: k = 0 is v,
// k = 1..6 are v + h e_a (k odd) and v - h e_a (k even), a = (k - 1) / 2. Each f - v of
// k >= 1 is added with mls3_stencil_add, and mls3_stencil_jacobian ends. mls3_jacobian walks
// k in a loop around one evaluation of f (mls3_eval is most of a program's code: one copy,
// not six, keeps the program small); mls3_eval_jacobian falls back to it.
vec3 mls3_stencil_axis(int k) {
    return k == 0 ? vec3(0.0) : vec3(equal(ivec3((k - 1) / 2), ivec3(0, 1, 2)));
}

float mls3_stencil_sign(int k) {
    return (k & 1) == 1 ? 1.0 : -1.0;
}

vec3 mls3_stencil_point(vec3 v, int k, float h) {
    return v + (mls3_stencil_sign(k) * h) * mls3_stencil_axis(k);
}

// sums' column a: d(v + h e_a) - d(v - h e_a), d = f - v (k >= 1 only)
void mls3_stencil_add(inout mat3 sums, int k, vec3 d) {
    sums += outerProduct(mls3_stencil_sign(k) * d, mls3_stencil_axis(k));
}

// Row a of J: e_a + (d(v + h e_a) - d(v - h e_a)) / (the steps float32 took).
mat3 mls3_stencil_jacobian(vec3 v, float h, mat3 sums) {
    mat3 rows;
    for (int a = 0; a < 3; ++a) {
        vec3 axis = vec3(equal(ivec3(a), ivec3(0, 1, 2)));
        vec3 up = v + h * axis;
        vec3 down = v - h * axis;
        float taken = dot(up - v, axis) + dot(v - down, axis);
        rows[a] = axis + sums[a] / taken;
    }
    return transpose(rows);
}

// Whether the last J took affine's plain solve (mls3_solve_plain) at each of its six probes
// (mls3_jacobian) or is its derivative at v (mls3_eval_jacobian): with every target on one
// plane, f maps each probe, or v's neighbourhood, into it, and J's rows, differences of
// those images or their derivatives, lie in it; so J is singular, exactly but for float32's
// rounding.
bool mls3_jacobian_plain = false;

// J = df/dv at v by central differences of step h (scaled; 6 evaluations of f, one site).
mat3 mls3_jacobian(vec3 v, float h) {
    mat3 sums = mat3(0.0);
    bool plain = true;
    for (int k = 1; k <= 6; ++k) {
        mls3_stencil_add(sums, k, mls3_eval(mls3_stencil_point(v, k, h)).d);
        plain = plain && mls3_solve_plain;
    }
    mls3_jacobian_plain = plain;
    return mls3_stencil_jacobian(v, h, sums);
}

// f and J = df/dv together (the points pass's J), J by differentiating the solve: every
// moment (W, sum w P, sum w E, A, D, about the centre's nearest handle o) is linear in the
// weights, so its derivative along axis a is the same sum with each weight w replaced by
// dw/dv_a = -2 (p_a - v_a) dw/d(d2) (mls3_slope_at: the weight's own slope, exact), one pass
// over the handles per axis. The centring (p* = p_o + P / W, A - P P^T / W, ...) and the
// plain branch's solve are then differentiated in closed form (mls3_derivative_row): affine's
// N = A^-1 D gives dN = A^-1 (dD - dA N); the rotations' polar factor U of B = U H moves by
// U [w]x with (tr(H) I - H) w = axial(U^T dB - dB^T U), and similarity's scale with
// <U, dB> and tr(dA). So J carries float32's rounding, not a step's O(h^2) f''' (central
// differences). A weight's normalisation, common to all handles at v (mls/weights.glsl), is
// held fixed: MLS ignores a common factor, so its derivative drops out; so is the gaussian's
// cap on the nearest handle's weight (the only one it can hold: its P is 0, and its weight
// enters p* and the centring at e^-60 of the others'). Where the solve did not take its
// plain branch (a degenerate set, the ridge's rules: mls3/solve_full.glsl) the same
// moments' derivatives go through that float64 solve (mls3_ridge_rows). Where v snaps to
// a handle, or where J would not be finite, J is mls3_jacobian's central differences of
// step h; f is mls3_eval's, bit for bit.
struct MLS3Centre {
    bool plain;   // well inside the plain branch of mls3_solve
    float W;
    vec3 P;       // sum w P (about o)
    vec3 dp;      // p* - p_o and e* - e_o
    vec3 de;
    vec3 pst;     // p*
    float inv;    // 1 / trace of the centred A: A, D and their derivatives in its units
    mat3 A;       // the centred moments, normalised
    mat3 D;
    bool zero;    // D = 0: every displacement equal, N = 0
    mat3 N;       // the solve: f - v = e* + (v - p*) N
    vec3 l0;      // affine: A's Cholesky factor
    vec3 l1;
    vec3 l2;
    mat3 B;       // the rotations: A + D, its polar factor U, (tr(H) I - H)^-1 (H = U^T B)
    mat3 U;
    mat3 G;
};

// The centre's moments as mls3_solve takes them, and whether it took their plain branch,
// where f is the plain closed form about v (the ridge 0): J is its derivative. U: B's polar
// factor where mls3_solve took that branch for the same moments (mls3_solve_polar), else 0.
MLS3Centre mls3_centre(MLS3Accum b, mat3 U) {
    MLS3Centre c;
    c.W = b.W;
    c.P = b.P;
    // mls3_finish's centring, and the solve's normalisation
    vec3 a, o;
    mls3_centred(b, c.dp, c.de, a, o, c.D);
    c.pst = b.op + c.dp;
    c.inv = 1.0 / (a.x + a.y + a.z);
    a *= c.inv;
    o *= c.inv;
    c.D *= c.inv;
    c.A = mat3(vec3(a.x, o.x, o.y), vec3(o.x, a.y, o.z), vec3(o.y, o.z, a.z));
    float tr = a.x + a.y + a.z;
    float c2 = a.x * a.y + a.x * a.z + a.y * a.z - dot(o, o);
    c.zero = c.D[0] == vec3(0.0) && c.D[1] == vec3(0.0) && c.D[2] == vec3(0.0);
    c.B = c.A + c.D;
    c.U = mat3(1.0);
    c.G = mat3(1.0);
    c.l0 = vec3(1.0);
    c.l1 = vec3(0.0, 1.0, 0.0);
    c.l2 = vec3(0.0, 0.0, 1.0);
#if MLS_TRANSFORM == 0
    // the solve's branch is mls3_solve_plain (mls3_eval_jacobian): A^-1 D by Cholesky, or in
    // float64 where A's least eigenvalue is 1e-3 to 1e-2 of its trace (no ridge either way)
    c.plain = b.W > 0.0;
    c.l0 = vec3(sqrt(a.x), o.x, o.y);
    c.l0.yz /= c.l0.x;
    float l11 = sqrt(a.y - c.l0.y * c.l0.y);
    c.l1 = vec3(0.0, l11, (o.z - c.l0.z * c.l0.y) / l11);
    c.l2 = vec3(0.0, 0.0, sqrt(a.z - c.l0.z * c.l0.z - c.l1.z * c.l1.z));
    c.plain = c.plain && l11 > 0.0 && c.l2.z > 0.0;
    c.N = mat3(mls3_cholesky_apply(c.l0, c.l1, c.l2, c.D[0]),
               mls3_cholesky_apply(c.l0, c.l1, c.l2, c.D[1]),
               mls3_cholesky_apply(c.l0, c.l1, c.l2, c.D[2]));
#else
    float nb2 = dot(c.B[0], c.B[0]) + dot(c.B[1], c.B[1]) + dot(c.B[2], c.B[2]);
    // U = 0: the solve took another branch (mls3_finish), a ridge or Horn's rotation of a B
    // that reflects; else f is U's closed form (mls3_solve, or mls3_solve_full where B is
    // near singular), and its derivative needs tr(H) I - H invertible (B of rank 2 or more)
    c.plain = b.W > 0.0 && determinant(U) > 0.5 && c2 > 0.0 && nb2 > 0.0;
    c.U = U;
    mat3 H = transpose(c.U) * c.B;
    H = 0.5 * (H + transpose(H));
    c.G = inverse((H[0][0] + H[1][1] + H[2][2]) * mat3(1.0) - H);
    mat3 NR = c.U - mat3(1.0);
#if MLS_TRANSFORM == 2
    c.N = NR;
#else
    float gain = c.D[0][0] + c.D[1][1] + c.D[2][2]
               + dot(NR[0], c.B[0]) + dot(NR[1], c.B[1]) + dot(NR[2], c.B[2]);
    c.N = ((tr + gain) / tr) * NR + (gain / tr) * mat3(1.0);
#endif
#endif
    c.N = c.zero ? mat3(0.0) : c.N;
    return c;
}

// dw/d(d2) of handle i at p, as mls3_weight_at weighs it: 0 where that gives no weight, and
// where MLS_WEIGHT_NEXT's least distance near2 holds the weight flat. Near d = R a radius
// weight's slope, unlike the weight itself, is no difference of nearly equal numbers: float32
// keeps it.
float mls3_slope_at(MLS3Accum a, vec3 p, bool use) {
    vec3 dp = p - a.v;
    float d2 = dot(dp, dp);
    bool none;
    float seen = mls3_seen(a, d2, use, none);
    none = none || seen > d2;
#if MLS_REACH_GAUSSIAN
    float x = mls3_excess(a, p);
    float raw = mls_gaussian_excess(x);
    float slope = mls_gaussian_excess_slope(x, raw);
#else
    float taken = mls_function_d2(d2, seen);
    float raw = MLS_WEIGHT_FUNCTION(taken, a.g, a.inv_m, a.sigma);
    float slope = MLS_SLOPE_FUNCTION(taken, raw, a.g, a.inv_m, a.sigma);
#endif
    slope = mls_interpolated_slope(raw, slope, seen, a.inv_m);
    return none ? 0.0 : slope;
}

// Handle i's terms of the moments' derivative along ``axis`` (d2 = |p - v|^2 moves by
// -2 (p_a - v_a) per unit of v_a)
void mls3_slope_accumulate(inout MLS3Accum s, MLS3Accum a, int axis, int i, bool use) {
    vec3 p = mls3_p(i);
    float wdot = mls3_slope_at(a, p, use) * (-2.0 * (p[axis] - a.v[axis]));
    mls3_add(s, wdot, p - a.op, mls3_e(i) - a.oe, 0.0);
}
#define MLS3_SLOPE_ACC(i, use) mls3_slope_accumulate(s, a, axis, i, use);

// Row ``axis`` of J, e_a + d(f - v)/dv_a, from the centre c and the moments' derivative s
vec3 mls3_derivative_row(MLS3Centre c, MLS3Accum s, vec3 v, int axis) {
    vec3 unit = vec3(equal(ivec3(axis), ivec3(0, 1, 2)));
    float invW = 1.0 / c.W;
    vec3 dp1 = (s.P - c.dp * s.W) * invW;   // d(p*)/dv_a
    vec3 de1 = (s.E - c.de * s.W) * invW;   // d(e*)/dv_a
    // the centred moments' derivatives (P dp^T = P P^T / W and P de^T = P E^T / W, by parts)
    vec3 a1 = (s.Ad - (s.P * c.dp + c.P * dp1)) * c.inv;
    vec3 o1 = (s.Ao - (s.P.xxy * c.dp.yzz + c.P.xxy * dp1.yzz)) * c.inv;
    mat3 D1 = (s.D - outerProduct(s.P, c.de) - outerProduct(c.P, de1)) * c.inv;
    mat3 A1 = mat3(vec3(a1.x, o1.x, o1.y), vec3(o1.x, a1.y, o1.z), vec3(o1.y, o1.z, a1.z));
#if MLS_TRANSFORM == 0
    mat3 R = D1 - A1 * c.N;
    mat3 N1 = mat3(mls3_cholesky_apply(c.l0, c.l1, c.l2, R[0]),
                   mls3_cholesky_apply(c.l0, c.l1, c.l2, R[1]),
                   mls3_cholesky_apply(c.l0, c.l1, c.l2, R[2]));
#else
    mat3 B1 = A1 + D1;
    mat3 K = transpose(c.U) * B1;
    K -= transpose(K);
    vec3 w = c.G * vec3(K[1][2], K[2][0], K[0][1]);
    mat3 U1 = c.U * mls3_cross_matrix(w);
#if MLS_TRANSFORM == 2
    mat3 N1 = U1;
#else
    // N = (along / tr) (U - I) + (gain / tr) I, along = tr + gain, gain = tr(D) + <U - I, B>
    mat3 NR = c.U - mat3(1.0);
    float tr = c.A[0][0] + c.A[1][1] + c.A[2][2];
    float tr1 = a1.x + a1.y + a1.z;
    float gain = c.D[0][0] + c.D[1][1] + c.D[2][2]
               + dot(NR[0], c.B[0]) + dot(NR[1], c.B[1]) + dot(NR[2], c.B[2]);
    float gain1 = D1[0][0] + D1[1][1] + D1[2][2]
                + dot(U1[0], c.B[0]) + dot(U1[1], c.B[1]) + dot(U1[2], c.B[2])
                + dot(NR[0], B1[0]) + dot(NR[1], B1[1]) + dot(NR[2], B1[2]);
    float along = tr + gain;
    float along1 = tr1 + gain1;
    mat3 N1 = ((along1 * tr - along * tr1) / (tr * tr)) * NR + (along / tr) * U1
            + ((gain1 * tr - gain * tr1) / (tr * tr)) * mat3(1.0);
#endif
#endif
    bool still = D1[0] == vec3(0.0) && D1[1] == vec3(0.0) && D1[2] == vec3(0.0);
    N1 = c.zero && still ? mat3(0.0) : N1;   // every displacement equal: N = 0 about v
    return unit + de1 + (unit - dp1) * c.N + (v - c.pst) * N1;
}

// The moments' derivative along ``axis`` (a constant at each call, as every coordinate
// index below): one pass over the handles, each weight replaced by its derivative
MLS3Accum mls3_slope_sums(MLS3Accum a, MLS3Accum zero, int axis) {
    int n = u_mls3_count;
    MLS3Accum s = zero;
    MLS3_EACH(MLS3_SLOPE_ACC)
    return s;
}

#if !MLS3_SOLVE_LATER
// J's rows (d f / dv_a) where f is not the plain branch's closed form (a degenerate set's ridges, Horn's
// rotation where B is near singular or reflects: mls3_solve_full), from the same moments'
// derivatives s[a] along each axis: the centring differentiated as in mls3_derivative_row,
// in float64 about the float64 moments that f came from (mls3_finish_full), and the solve,
// N = mls3_solve_full(A, D), by central differences in the moments, N' = (N(A + t A', D +
// t D') - N(A - t A', D - t D')) / 2t, with t A' and t D' a millionth of trace A: the
// rules' ridges are smooth in the moments (their (1 - e / share)^2 and (A + g)^-1 turn
// within ~1e-3 of the trace, so the differences' O(t^2) error is ~1e-6 of N'; float64's
// rounding over t, ~1e-10), where differences of f over a step h in v (mls3_jacobian) err
// by h^2 f''', a few 1e-2 of J in a gaussian's tail (R = 4, handles 15-25 voxels apart).
// One call site of the solve, in a loop (its code is most of a program's: one copy). Where
// f came from mls3_finish_full at a (mls3_full_kept), its moments and N are taken as they
// are; else (the plain branch's f, whose derivative failed) summed and solved here.
mat3 mls3_ridge_rows(MLS3Accum a, MLS3Accum s[3], vec3 v) {
    bool kept = mls3_full_kept;
    MLS3Sums64 m = mls3_full_sums;
    dvec3 dp = mls3_full_dp, de = mls3_full_de;
    dmat3 N = mls3_full_N;
    if (!kept) {
        m = mls3_sums64(a);
        mls3_centred64(m, dp, de);
    }
    double spread = double(mls_yardstick(a.yard));
    double invW = 1.0lf / m.W;
    dvec3 dp1[3], de1[3], a1[3], o1[3];
    dmat3 D1[3];
    double largest = 0.0lf;
    for (int axis = 0; axis < 3; ++axis) {
        double sW = double(s[axis].W);
        dvec3 sP = dvec3(s[axis].P);
        dp1[axis] = (sP - dp * sW) * invW;
        de1[axis] = (dvec3(s[axis].E) - de * sW) * invW;
        a1[axis] = dvec3(s[axis].Ad) - (sP * dp + m.P * dp1[axis]);
        o1[axis] = dvec3(s[axis].Ao) - (sP.xxy * dp.yzz + m.P.xxy * dp1[axis].yzz);
        D1[axis] = dmat3(s[axis].D) - outerProduct(sP, de) - outerProduct(m.P, de1[axis]);
        dvec3 big = max(max(abs(a1[axis]), abs(o1[axis])),
                        max(max(abs(D1[axis][0]), abs(D1[axis][1])), abs(D1[axis][2])));
        largest = max(largest, max(big.x, max(big.y, big.z)));
    }
    double mu = m.Ad.x + m.Ad.y + m.Ad.z;
    double t = largest > 0.0lf ? 1e-6lf * mu / largest : 1.0lf;
    dmat3 N1[3];
    for (int k = kept ? 1 : 0; k < 7; ++k) {
        // k = 0 the moments themselves; 2 a + 1 and 2 a + 2 along axis a, up and down
        int axis = max(k - 1, 0) / 2;
        double step = k == 0 ? 0.0lf : ((k & 1) == 1 ? t : -t);
        dmat3 Nk = mls3_solve_full(m.Ad + step * a1[axis], m.Ao + step * o1[axis],
                                   m.D + step * D1[axis], spread);
        if (k == 0) {
            N = Nk;
        } else if ((k & 1) == 1) {
            N1[axis] = Nk;
        } else {
            N1[axis] = (N1[axis] - Nk) / (2.0lf * t);
        }
    }
    dvec3 far = dvec3(v) - (dvec3(a.op) + dp);   // v - p*
    mat3 rows;
    for (int axis = 0; axis < 3; ++axis) {
        dvec3 unit = dvec3(equal(ivec3(axis), ivec3(0, 1, 2)));
        rows[axis] = vec3(unit + de1[axis] + (unit - dp1[axis]) * N + far * N1[axis]);
    }
    return rows;
}
#endif

// MLS3_JACOBIAN_LATER: where J needs mls3_jacobian's six evaluations of f, J is left I and
// mls3_jacobian_later set, for the caller's second pass over those points alone (a GPU's
// warp, and a CPU renderer's vector whatever its lanes' mask, would run them for all).
#ifndef MLS3_JACOBIAN_LATER
#define MLS3_JACOBIAN_LATER 0
#endif
bool mls3_jacobian_later = false;

MLS3Result mls3_eval_jacobian(vec3 v, float h, out mat3 J) {
    int n = u_mls3_count;
    float d2min = 3.0e38;
    float d2next = 3.0e38;
    int nearest = 0;
    int next = 0;
    MLS3_EACH(MLS3_NEAR)
    MLS3Accum a = mls3_begin(v, d2min, d2next, nearest, next, n);
    MLS3Accum zero = a;   // no moments yet
    MLS3_EACH(MLS3_ACC)
    MLS3Result r = mls3_finish(a);
    MLS3Centre c = mls3_centre(a, mls3_solve_polar);
    bool plain_solve = mls3_solve_plain;   // mls3_ridge_rows's solves set it again
    bool exact = !a.hit && c.plain && (MLS_TRANSFORM != 0 || plain_solve);
    // no handle within reach (radius weights, the nearest at least R away): f = v about v
    bool alone = !a.hit && !(a.W > 0.0) && a.m >= u_radius * u_radius;
    // the other solves' derivative (mls3_ridge_rows), from the same moments' derivatives
    bool ridge = !exact && !a.hit && a.W > 0.0 && !alone
              && MLS3_JACOBIAN_LATER == 0 && MLS3_SOLVE_LATER == 0;
    mat3 rows = mat3(1.0);
    if (exact || ridge) {
        MLS3Accum s[3];
        s[0] = mls3_slope_sums(a, zero, 0);
        s[1] = mls3_slope_sums(a, zero, 1);
        s[2] = mls3_slope_sums(a, zero, 2);
        if (exact) {
            rows[0] = mls3_derivative_row(c, s[0], v, 0);
            rows[1] = mls3_derivative_row(c, s[1], v, 1);
            rows[2] = mls3_derivative_row(c, s[2], v, 2);
        } else {
#if !MLS3_SOLVE_LATER
            rows = mls3_ridge_rows(a, s, v);
#endif
        }
        bool finite = !any(isnan(rows[0])) && !any(isinf(rows[0])) && !any(isnan(rows[1]))
                    && !any(isinf(rows[1])) && !any(isnan(rows[2])) && !any(isinf(rows[2]));
        exact = exact && finite;
        ridge = ridge && finite;
    }
    // affine's plain solve at the centre (mls3_solve_plain), which f and J took
    mls3_jacobian_plain = (exact || (ridge && plain_solve)) && MLS_TRANSFORM == 0;
    if (alone) {
        J = mat3(1.0);
    } else if (exact || ridge) {
        J = transpose(rows);
    } else {
#if MLS3_JACOBIAN_LATER
        J = mat3(1.0);
        mls3_jacobian_later = true;
#else
        J = mls3_jacobian(v, h);
#endif
    }
    return r;
}

vec3 mls3_f(vec3 v) {
    return mls3_eval(v).f;
}

void mls3(vec3 v, out mat3 M, out vec3 T) {
    MLS3Result r = mls3_eval(v);
    M = r.M;
    T = r.f - v * r.M;
}

// f in voxels: v + (f - v), so that the identity returns v itself
vec3 mls3_f_voxels(vec3 voxel) {
    return voxel + (mls3_eval(mls3_to_scaled(voxel)).d * u_mls3_scale + u_mls3_offset);
}
