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
//   MLS3Result mls3_eval_jacobian(vec3 v, float h, out mat3 J)   f, and J from the same
//                                           differences with one pass over the handles per axis
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
// see mls_gaussian_offset).
void mls3_nearest(inout float d2min, inout float d2next, inout int nearest, vec3 v, int i,
                  bool use) {
    vec3 dp = mls3_p(i) - v;
    float d2 = use ? dot(dp, dp) : 3.0e38;
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

MLS3Accum mls3_begin(vec3 v, float d2min, float d2next, int nearest, int n) {
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
    a.g_o = a.g - dot(u, u);
    a.twice_u = 2.0 * u;
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

// The weight of handle i at p (its squared distance to v in d2)
float mls3_weight_at(MLS3Accum a, vec3 p, bool use, out float d2) {
    vec3 dp = p - a.v;
    d2 = dot(dp, dp);
    // an empty slot, and the snapped handle (and duplicates of it: their weight is
    // infinite and their p^ zero), get no weight
#if MLS_WEIGHT_NEXT
    float seen = max(d2, a.near2);
#else
    float seen = d2;
#endif
    bool none = !use || (u_snap && d2 <= u_hit2);
#ifdef MLS_WEIGHT_FUNCTION64
    if (!none && mls_at_edge(d2)) {
        // near d = R: d2 exact in float64 (of float32 p and v), and the weight from it
        dvec3 dp64 = dvec3(p) - dvec3(a.v);
        return mls_weight_edge(dot(dp64, dp64), a.g, a.inv_m, a.sigma, seen);
    }
#endif
#if MLS_REACH_GAUSSIAN
    // d2 - g about the nearest handle, as mls/core.glsl's mls_handle_weight takes it
    vec3 P = p - a.op;
    float w = mls_weight_excess(dot(P, P - a.twice_u) - a.g_o, seen, a.inv_m);
#else
    float w = mls_weight(seen, a.g, a.inv_m, a.sigma);
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

// f at a point that mls3_solve left: its moments summed again in float64 and every rule of
// the solve (mls3_solve_full)
MLS3Result mls3_finish_full(MLS3Accum a) {
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
    dvec3 pst = dvec3(a.op);
    dvec3 est = dvec3(a.oe);
    if (!a.hit) {
        dvec3 dp = s.P / s.W;
        dvec3 de = s.E / s.W;
        pst += dp;
        est += de;
        s.Ad -= s.P * dp;
        s.Ao -= s.P.xxy * dp.yzz;
        s.D -= outerProduct(s.P, de);
    }
    dmat3 N = mls3_solve_full(s.Ad, s.Ao, s.D, double(mls_yardstick(a.yard)));
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

MLS3Result mls3_finish(MLS3Accum a) {
    mls3_solve_plain = false;
    if (!a.hit && !(a.W > 0.0)) {
        return mls3_identity(a.v);   // no handle reaches v (or there are none)
    }
    vec3 pst = a.op;
    vec3 est = a.oe;
    if (!a.hit) {
        // p* = p_o + sum w P / W, e* likewise, and the moments about them
        vec3 dp = a.P / a.W;
        vec3 de = a.E / a.W;
        pst += dp;
        est += de;
        a.Ad -= a.P * dp;
        a.Ao -= a.P.xxy * dp.yzz;
        a.D -= outerProduct(a.P, de);
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
#define MLS3_NEAR(i, use) mls3_nearest(d2min, d2next, nearest, v, i, use);
#define MLS3_ACC(i, use) mls3_accumulate(a, i, use);

MLS3Result mls3_eval(vec3 v) {
    int n = u_mls3_count;
    float d2min = 3.0e38;
    float d2next = 3.0e38;
    int nearest = 0;
    MLS3_EACH(MLS3_NEAR)
    MLS3Accum a = mls3_begin(v, d2min, d2next, nearest, n);
    MLS3_EACH(MLS3_ACC)
    return mls3_finish(a);
}

// J = df/dv by central differences of step h (scaled), for row vectors: df = dv * J, the
// mathematical J[r][c] = d f_c / d v_r (the GLSL J[c][r]). The stencil's points: k = 0 is v,
// k = 1..6 are v + h e_a (k odd) and v - h e_a (k even), a = (k - 1) / 2. Each f - v of
// k >= 1 is added with mls3_stencil_add, and mls3_stencil_jacobian ends. mls3_jacobian walks
// k in a loop around one evaluation of f (mls3_eval is most of a program's code: one copy,
// not six, keeps the program small); mls3_eval_jacobian shares the passes over the handles.
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

// Whether the last J (mls3_jacobian, mls3_eval_jacobian) took affine's plain solve at each
// of its six probes (mls3_solve_plain): with every target on one plane, f maps each probe
// into it, and J's rows, differences of those images, lie in it; so J is singular, exactly
// but for float32's rounding.
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

// f and J = df/dv together (the points pass's J): the central differences of mls3_jacobian,
// with the moments of the probes v +- h e_a from one pass over the handles per axis a instead
// of a full evaluation of f per probe. Every moment (W, sum w P, sum w E, A, D) is linear in
// the weights: about the centre's nearest handle o, the probe's are M0 +- Delta_a, M0 the
// centre's and Delta_a the moments of the half differences (w(v + h e_a) - w(v - h e_a)) / 2
// (features 1, P, E, P P^T, P^T E, each handle's P and E once for all probes). M0 stands for
// the probes' mean (M(v + h e_a) + M(v - h e_a)) / 2, which moves J by O(h^2) as the
// differences themselves do; W itself is summed exactly per probe (o's own weight, the one
// that varies fastest near o, has P = E = 0 and enters W alone). Each probe then finishes by
// the short solve below (mls3_probe_d).
//
// The probes' weights take one normalisation m_lo = (sqrt(m) - 1.1 h)^2, below every probe's
// squared distance to any handle (mls/weights.glsl divides a weight by a factor common to
// all handles: the centre's m would clip gaussian's max(d2 - m, 0) at a probe nearer to a
// handle than the centre), and M0 is rescaled to it by lambda = w(m; m_lo) / w(m; m). Where
// a probe may come within the snapping distance of a handle, where no handle reaches the
// centre (J = I where none reaches any probe), where a probe's W is not positive, or where
// the centre is not well inside the solve's plain branch, J is mls3_jacobian's own; f is
// mls3_eval's, bit for bit.
struct MLS3Probes {
    int axis;       // a
    float up;       // v_a + h and v_a - h: the probes' moved coordinate
    float down;
    float m;        // the probes' normalisation m_lo
    float inv_m;
    float sigma;
    float Wup;      // sum w(v + h e_a) and sum w(v - h e_a)
    float Wdown;
    MLS3Accum delta;   // Delta_a (its W unused)
#if MLS_REACH_GAUSSIAN
    float h;        // the probes' step
    vec3 twice_u;   // the centre's (MLS3Accum)
    float g_o;      // ... less g - m_lo: a handle's d2 - m_lo at the centre is P.(P - 2u) - g_o
#endif
};

void mls3_probe_accumulate(inout MLS3Probes s, vec3 v, vec3 op, vec3 oe, int i, bool use) {
    vec3 p = mls3_p(i);
    vec3 dp = p - v;
    vec3 sq = dp * dp;
    // a probe's squared distance: the centre's with coordinate a moved
    float pa = p[s.axis];
    float rest = s.axis == 0 ? sq.y + sq.z : (s.axis == 1 ? sq.x + sq.z : sq.x + sq.y);
    float du = pa - s.up;
    float dd = pa - s.down;
    vec3 P = p - op;
#if MLS_REACH_GAUSSIAN
    // d2 - m_lo at each probe from the centre's excess (mls3_weight_at), precise far from
    // the handles: moving coordinate a by +-h adds h (h -+ 2 (p_a - v_a)) to d2
    float excess = dot(P, P - s.twice_u) - s.g_o;
    float wu = use ? mls_weight_excess(excess + s.h * (s.h - 2.0 * dp[s.axis]), du * du + rest,
                                       s.inv_m) : 0.0;
    float wd = use ? mls_weight_excess(excess + s.h * (s.h + 2.0 * dp[s.axis]), dd * dd + rest,
                                       s.inv_m) : 0.0;
#else
    float wu = use ? mls_weight(du * du + rest, s.m, s.inv_m, s.sigma) : 0.0;
    float wd = use ? mls_weight(dd * dd + rest, s.m, s.inv_m, s.sigma) : 0.0;
#endif
    s.Wup += wu;
    s.Wdown += wd;
    mls3_add(s.delta, 0.5 * (wu - wd), P, mls3_e(i) - oe, 0.0);
}

// The probe v + sign h e_a: lambda M0 + sign Delta_a, W its own.
MLS3Accum mls3_probe(MLS3Accum a, MLS3Accum delta, float W, float lambda, float sign,
                     vec3 point) {
    MLS3Accum b = a;
    b.v = point;
    b.W = W;
    b.P = lambda * a.P + sign * delta.P;
    b.E = lambda * a.E + sign * delta.E;
    b.Ad = lambda * a.Ad + sign * delta.Ad;
    b.Ao = lambda * a.Ao + sign * delta.Ao;
    b.D = lambda * a.D + sign * delta.D;
    return b;
}

#define MLS3_PROBE_ACC(i, use) mls3_probe_accumulate(s, v, a.op, a.oe, i, use);

// The probes' short solve. Where the centre's moments are well inside the closed forms'
// plain branch (every eigenvalue of A above 2e-3 trace A for affine, A^-1 D by Cholesky; the
// middle one above 2e-3 and det B > 0.02 |B|^3 for the rotations, B's polar factor), so is
// each probe's, O(h) away: affine solves by Cholesky alone; the rotations take the centre's
// polar factor U (B = U H) to first order in the probe's B - B0, U (I + [w]x) with
// (tr(H) I - H) w = axial(U^T dB - dB^T U). The error, O(h^2) and the same at both probes of
// an axis, leaves their difference O(h^3): J as the differences of the full solves.
struct MLS3Centre {
    bool plain;   // the centre is in that branch
    mat3 B;       // its normalised B, polar factor U, and (tr(H) I - H)^-1
    mat3 U;
    mat3 G;
};

// finish's centring and the solve's normalisation: A (diagonal a, off-diagonal o) and D in
// units of trace(A), and p*, e*
void mls3_moments(MLS3Accum b, out vec3 a, out vec3 o, out mat3 D, out vec3 pst, out vec3 est) {
    vec3 dp = b.P / b.W;
    vec3 de = b.E / b.W;
    pst = b.op + dp;
    est = b.oe + de;
    a = b.Ad - b.P * dp;
    o = b.Ao - b.P.xxy * dp.yzz;
    D = b.D - outerProduct(b.P, de);
    float inv = 1.0 / (a.x + a.y + a.z);
    a *= inv;
    o *= inv;
    D *= inv;
}

// (U: B's polar factor where mls3_solve took it for the same moments, mls3_solve_polar; the
// plain branch here lies within that one)
MLS3Centre mls3_centre(MLS3Accum b, mat3 U) {
    vec3 a, o, pst, est;
    mat3 D;
    mls3_moments(b, a, o, D, pst, est);
    MLS3Centre c;
    float tr = a.x + a.y + a.z;
    float c2 = a.x * a.y + a.x * a.z + a.y * a.z - dot(o, o);
    float det = a.x * (a.y * a.z - o.z * o.z) - o.x * (o.x * a.z - o.z * o.y)
              + o.y * (o.x * o.z - a.y * o.y);
    mat3 A = mat3(vec3(a.x, o.x, o.y), vec3(o.x, a.y, o.z), vec3(o.y, o.z, a.z));
    c.B = A + D;
#if MLS_TRANSFORM == 0
    c.plain = b.W > 0.0 && c2 > 4.0 * MLS3_PLAIN_AFFINE * tr * tr;
    c.plain = c.plain && det > 2.0 * MLS3_PLAIN_AFFINE * c2 * tr;
    c.U = mat3(1.0);
    c.G = mat3(1.0);
#else
    float nb2 = dot(c.B[0], c.B[0]) + dot(c.B[1], c.B[1]) + dot(c.B[2], c.B[2]);
    c.plain = b.W > 0.0 && c2 > 4.0 * MLS3_DEGENERATE_SHARE * tr * tr;
    c.plain = c.plain && determinant(c.B) > 2.0 * MLS3_POLAR_DET * nb2 * sqrt(nb2);
    c.U = U;
    mat3 H = transpose(c.U) * c.B;
    H = 0.5 * (H + transpose(H));
    c.G = inverse((H[0][0] + H[1][1] + H[2][2]) * mat3(1.0) - H);
#endif
    return c;
}

// ``plain`` becomes false where a probe (moments b, f - v = d by the short solve) is not in
// the plain branch of mls3_solve itself: its moments, the centre's moved by O(h), can leave
// it where h is not small against the handles' spread about p* (a cluster of handles a few
// h away), and Cholesky took the root of a negative pivot there (NaN in J)
void mls3_check_probe(inout bool plain, MLS3Accum b, vec3 d, float Wmean) {
    vec3 a, o, pst, est;
    mat3 D;
    mls3_moments(b, a, o, D, pst, est);
    // the moments stand for the probes' mean, off by O(h^2); W is exact: their mismatch,
    // magnified by the handles' spread about o against that about p*, moves A
    float spread_o = b.Ad.x + b.Ad.y + b.Ad.z;
    float spread_c = spread_o - dot(b.P, b.P) / b.W;
    float mismatch = abs(b.W - Wmean) / b.W * spread_o / max(spread_c, 1e-30);
    plain = plain && mismatch < 1e-3;
    float tr = a.x + a.y + a.z;
    float c2 = a.x * a.y + a.x * a.z + a.y * a.z - dot(o, o);
#if MLS_TRANSFORM == 0
    float det = a.x * (a.y * a.z - o.z * o.z) - o.x * (o.x * a.z - o.z * o.y)
              + o.y * (o.x * o.z - a.y * o.y);
    bool ok = c2 > 2.0 * MLS3_PLAIN_AFFINE * tr * tr && det > MLS3_PLAIN_AFFINE * c2 * tr;
#else
    bool ok = c2 > 2.0 * MLS3_DEGENERATE_SHARE * tr * tr;
    mat3 A = mat3(vec3(a.x, o.x, o.y), vec3(o.x, a.y, o.z), vec3(o.y, o.z, a.z));
    mat3 B = A + D;
    float nb2 = dot(B[0], B[0]) + dot(B[1], B[1]) + dot(B[2], B[2]);
    ok = ok && determinant(B) > MLS3_POLAR_DET * nb2 * sqrt(nb2);
#endif
    plain = plain && ok && !any(isnan(d)) && !any(isinf(d));
}

// f - v at a probe (moments b) by the short solve
vec3 mls3_probe_d(MLS3Accum b, MLS3Centre c) {
    vec3 a, o, pst, est;
    mat3 D;
    mls3_moments(b, a, o, D, pst, est);
    bool zero = D[0] == vec3(0.0) && D[1] == vec3(0.0) && D[2] == vec3(0.0);
    float tr = a.x + a.y + a.z;
#if MLS_TRANSFORM == 0
    vec3 l0 = vec3(sqrt(a.x), o.x, o.y);
    l0.yz /= l0.x;
    float l11 = sqrt(a.y - l0.y * l0.y);
    vec3 l1 = vec3(0.0, l11, (o.z - l0.z * l0.y) / l11);
    vec3 l2 = vec3(0.0, 0.0, sqrt(a.z - l0.z * l0.z - l1.z * l1.z));
    mat3 N = mat3(mls3_cholesky_apply(l0, l1, l2, D[0]), mls3_cholesky_apply(l0, l1, l2, D[1]),
                  mls3_cholesky_apply(l0, l1, l2, D[2]));
#else
    mat3 A = mat3(vec3(a.x, o.x, o.y), vec3(o.x, a.y, o.z), vec3(o.y, o.z, a.z));
    mat3 B = A + D;
    mat3 K = transpose(c.U) * (B - c.B);
    K -= transpose(K);
    vec3 w = c.G * vec3(K[1][2], K[2][0], K[0][1]);
    mat3 NR = (c.U - mat3(1.0)) + c.U * mls3_cross_matrix(w);
    float gain = D[0][0] + D[1][1] + D[2][2]
               + dot(NR[0], B[0]) + dot(NR[1], B[1]) + dot(NR[2], B[2]);
    float along = tr + gain;
#if MLS_TRANSFORM == 2
    mat3 N = along > 1e-6 * tr ? NR : mat3(0.0);
#else
    mat3 N = (along / tr) * NR + (gain / tr) * mat3(1.0);
#endif
#endif
    N = zero ? mat3(0.0) : N;
    return est + (b.v - pst) * N;
}

// One axis a of mls3_eval_jacobian: Delta_a and the probes' W, then both probes' f - v into
// sums (a constant at each call: every coordinate index below is).
void mls3_probe_axis(inout mat3 sums, inout bool together, inout MLS3Probes s, MLS3Accum a,
                     MLS3Accum zero, MLS3Centre c, float lambda, vec3 v, float h, int axis) {
    int n = u_mls3_count;
    s.axis = axis;
    s.up = v[axis] + h;
    s.down = v[axis] - h;
    s.Wup = 0.0;
    s.Wdown = 0.0;
    s.delta = zero;
    MLS3_EACH(MLS3_PROBE_ACC)
    together = together && s.Wup > 0.0 && s.Wdown > 0.0;
    int k = 2 * axis + 1;
    MLS3Accum up = mls3_probe(a, s.delta, s.Wup, lambda, 1.0, mls3_stencil_point(v, k, h));
    MLS3Accum down = mls3_probe(a, s.delta, s.Wdown, lambda, -1.0,
                                mls3_stencil_point(v, k + 1, h));
    vec3 dup = mls3_probe_d(up, c);
    vec3 ddown = mls3_probe_d(down, c);
    mls3_check_probe(together, up, dup, lambda * a.W + s.delta.W);
    mls3_check_probe(together, down, ddown, lambda * a.W - s.delta.W);
    mls3_stencil_add(sums, k, dup);
    mls3_stencil_add(sums, k + 1, ddown);
}

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
    MLS3_EACH(MLS3_NEAR)
    MLS3Accum a = mls3_begin(v, d2min, d2next, nearest, n);
    MLS3Accum zero = a;   // no moments yet
    MLS3_EACH(MLS3_ACC)
    MLS3Result r = mls3_finish(a);
    MLS3Probes s;
    float reach = sqrt(a.m) - 1.1 * h;   // a bound on every probe's distance to a handle
    s.m = max(reach, 0.0) * max(reach, 0.0);
    s.inv_m = 1.0 / s.m;
    s.sigma = mls_sigma(s.m);
#if MLS_REACH_GAUSSIAN
    s.h = h;
    s.twice_u = a.twice_u;
    s.g_o = a.g_o - (a.g - s.m);
#endif
    // the factor from the centre's weights (offset a.g) to the probes' (s.m), the same for
    // every handle unless the gaussian's cap (mls/weights.glsl) bounds the nearest's
    float lambda = mls_weight(a.m, s.m, s.inv_m, s.sigma) / mls_weight(a.m, a.g, a.inv_m, a.sigma);
    MLS3Centre c = mls3_centre(a, mls3_solve_polar);
    bool uncapped = mls_radius_ratio(a.g - a.m) < MLS_GAUSSIAN_CAP;
    bool together = !a.hit && c.plain && s.m > u_hit2 && lambda > 1e-30 && lambda < 1e30;
    together = together && uncapped;
    // no handle within reach of any probe (radius weights): f - v = 0 at each, J = I
    bool alone = !a.hit && !(a.W > 0.0) && reach > u_radius;
    mat3 sums = mat3(0.0);
    mls3_probe_axis(sums, together, s, a, zero, c, lambda, v, h, 0);
    mls3_probe_axis(sums, together, s, a, zero, c, lambda, v, h, 1);
    mls3_probe_axis(sums, together, s, a, zero, c, lambda, v, h, 2);
    // together: each probe's short solve is affine's Cholesky (mls3_check_probe)
    mls3_jacobian_plain = together && MLS_TRANSFORM == 0;
    if (alone) {
        J = mat3(1.0);
    } else if (together) {
        J = mls3_stencil_jacobian(v, h, sums);
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
