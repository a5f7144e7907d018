// Moving Least Squares deformation (Schaefer, McPhail & Warren 2006) with the distance
// weights of Table 1 of "Extensions to the MLS method for image deformation".
//
// The one MLS implementation of glmls: the weights and the transforms. How the handles are
// visited (all of them, unrolled, or through spatial bins) is mls/visit.glsl, which every pass
// that needs f, M or T includes (it includes this file).
//
// Defines (glmls.engine.kernel.MLSKernel.defines):
//   MLS_WEIGHT_FUNCTION  the weight in use, a function of mls/weights.glsl
//   MLS_WEIGHT_USES_S    0 or 1: the weight needs idw's s, scaled per point (sigma)
//   MLS_TRANSFORM        index in glmls.core.config.TRANSFORMS: 0 affine, 1 similarity, 2 rigid
//   MLS_INTERPOLATING    0 or 1: multiply the weight by 1 / d^(2 alpha)
//   MLS_ALPHA_ONE        0 or 1: alpha == 1, so no pow() is needed
//   MLS_STORAGE          where the handles live (mls/handles.glsl)
//
// One pass over the handles (mls_begin, mls_accumulate per handle, mls_finish) accumulates
// every weighted moment; mls/visit.glsl's mls_eval(v) runs it.
//
// All coordinates are "scaled": (pixel - u_center) / u_scale, so that float32 keeps
// sub-millipixel precision on large images. The host scales s and R to match.
//
// Row-vector convention of the paper (eq. 1): f(v) = v M + T. M is returned as
// vec4(m00, m01, m10, m11), i.e. f.x = v.x m00 + v.y m10, f.y = v.x m01 + v.y m11.

#include "mls/handles.glsl"

#include "mls/weighting.glsl"

// glmls.reference.DEGENERATE_SHARE: below this share of trace A, A's small eigenvalue gets
// the ridge toward the similarity solution (affine)
#define MLS_DEGENERATE_SHARE 1e-3
// Below this share of trace A the float32 moments' rounding, magnified by trace / e2, shows in
// f: mls_finish asks for the float64 pass (mls/full.glsl) through mls_full_needed
#define MLS_FULL_SHARE 3e-2
bool mls_full_needed = false;
uniform bool u_snap_segments;   // the same as u_snap for segment handles (glmls.core.segments)
#if MLS_SEGMENTS
// the same as u_hit2 for segment handles, after the pole of their weight
// (glmls.engine.kernel.segment_hit2)
uniform float u_hit2_segments;
#endif

struct MLSResult {
    vec2 f;   // f(v), scaled coordinates
    vec2 d;   // f(v) - v, exactly 0 where every handle in reach stays (q = p)
    vec4 M;   // linear part, see above
};

MLSResult mls_identity(vec2 v) {
    MLSResult r;
    r.f = v;
    r.d = vec2(0.0);
    r.M = vec4(1.0, 0.0, 0.0, 1.0);
    return r;
}

// N = M - I for similarity / rigid, from mu = sum w |p^|^2 and the displacement moments
// D (see mls_finish). M = [[A, B], [-B, A]] / norm with A = mu + D11 + D22, B = D12 - D21.
vec4 mls_rotation_scale(float mu, vec4 D, float spread) {
    // Source handles in reach coincide (their spread about p* is float32 noise against the
    // spread about v of those not at the nearest one's place): only a translation is
    // defined.
    if (!(mu > 1e-13 * spread)) {
        return vec4(0.0);
    }
    float B = D.y - D.z;
#if MLS_TRANSFORM == 2
    // A and B relative to mu: next to a handle whose weight is steep the others' moments
    // can be ~1e-27, and their squares would underflow float32
    float A = 1.0 + (D.x + D.w) / mu;
    B /= mu;
    float n = sqrt(A * A + B * B);
    // Targets collapsed to a point: no rotation is defined, keep the identity.
    if (n <= 1e-6) {
        return vec4(0.0);
    }
    // A / n - 1 without cancellation for small rotations
    float c1 = A > 0.0 ? -B * B / (n * (A + n)) : A / n - 1.0;
    return vec4(c1, B / n, -B / n, c1);
#else
    float a = (D.x + D.w) / mu;
    return vec4(a, B / mu, -B / mu, a);
#endif
}

// One evaluation at v is two passes over the handles (mls_eval; callers that visit the
// handles otherwise, e.g. a spatial grid of bins, call the parts themselves):
//
// 1. mls_nearest_add: the nearest handle (for snapping) and the normalisation distance m,
//    a min over d^2, a few operations per handle;
// 2. mls_accumulate: every weighted moment at once, as plain sums about the nearest handle
//    o (P = p - p_o, E = e - e_o); mls_finish turns them into the means and central moments
//    (C = sum w P P^T - (sum w P)(sum w P)^T / W). About o, not the origin: differences of
//    nearby float32 values are exact, so P keeps its precision even for points far from a
//    tight cluster of handles, and where one handle dominates the weights (next to it) it is
//    o itself, adds nothing to the sums, and the correction term is second order in the
//    small weights, so no digits are lost. (A running-centroid Welford update is as precise
//    here and costs a division per handle more.)
//
// Both loops are branch-free: llvmpipe (and GPUs, per warp) run both sides of a branch
// whenever lanes disagree, so a "rare" branch costs its full price on every handle.
// Working with displacements e = q - p keeps the identity exact and small deformations
// precise: f(v) = v + e* + (v - p*) N with N = M - I.
struct MLSNearest {
    float d2min;    // squared distance of the nearest handle
    float d2far;    // ... of the nearest beyond the snapping distance
#if MLS_TRACK_NEXT
    float d2next;   // ... the least above d2min: the nearest handles apart from the nearest's
                    // place, whose weights the gaussian cut measures against (mls/visit.glsl)
#endif
    vec4 h;         // the nearest handle
#if MLS_SEGMENTS
    bool segment;   // it is a point of a segment handle (mls/segments.glsl)
#endif
#if MLS_REACH_GAUSSIAN
    vec2 pnext;     // the handle (or segment point) at d2next: the gaussian's offset is its
                    // excess about the nearest (mls_begin), exact where d2next itself is not
#endif
};

// The squared snapping distance of the nearest handle n.h: a point's, or a segment's.
float mls_hit2(MLSNearest n) {
#if MLS_SEGMENTS
    return n.segment ? u_hit2_segments : u_hit2;
#else
    return u_hit2;
#endif
}

// Whether v snaps to its nearest handle: its weight is infinite there and v within its
// snapping distance.
bool mls_snaps(MLSNearest n) {
#if MLS_SEGMENTS
    bool snaps = n.segment ? u_snap_segments : u_snap;
#else
    bool snaps = u_snap;
#endif
    return snaps && n.d2min <= mls_hit2(n);
}

MLSNearest mls_nearest_begin() {
    MLSNearest n;
    n.d2min = 3.0e38;
    n.d2far = 3.0e38;
#if MLS_TRACK_NEXT
    n.d2next = 3.0e38;
#endif
    n.h = vec4(0.0);
#if MLS_SEGMENTS
    n.segment = false;
#endif
#if MLS_REACH_GAUSSIAN
    n.pnext = vec2(0.0);
#endif
    return n;
}

// The least squared distance above the nearest's, with d2 seen at p (before d2min and the
// nearest take it): at the nearest apart from the nearest one's place.
void mls_nearest_next(inout MLSNearest n, float d2, vec2 p) {
#if MLS_REACH_GAUSSIAN
    n.pnext = d2 < n.d2min ? n.h.xy : (d2 > n.d2min && d2 < n.d2next ? p : n.pnext);
#endif
#if MLS_TRACK_NEXT
    mls_track_next(n.d2next, n.d2min, d2);
#endif
}

// ``use``: false for an empty slot (see MLS_UNROLL), which changes nothing.
void mls_nearest_add(inout MLSNearest n, vec4 h, vec2 v, bool use) {
    vec2 dp = h.xy - v;
    float d2 = use ? dot(dp, dp) : 3.0e38;
    bool nearer = d2 < n.d2min;
    mls_nearest_next(n, d2, h.xy);
    n.h = nearer ? h : n.h;
#if MLS_SEGMENTS
    n.segment = nearer ? false : n.segment;
#endif
    n.d2min = min(n.d2min, d2);
    n.d2far = min(n.d2far, d2 > u_hit2 ? d2 : 3.0e38);
}

struct MLSAccum {
    vec2 v;
    bool hit;       // v snaps to handle o: f(v) = its q
    vec4 o;         // the nearest handle: moments are taken about it
    float m;        // normalisation distance (see mls_weight)
    float g;        // the weights' offset: m, or for the gaussian the nearest handles' apart
                    // from the nearest one's place (mls_gaussian_offset)
#if MLS_REACH_GAUSSIAN
    float g_o;      // g - |v - p_o|^2, p_o = o.xy (mls_handle_weight)
    vec2 twice_u;   // 2 (v - p_o)
#endif
    float inv_m;    // 1 / m
    float sigma;    // idw: s / m^alpha
    float W;        // sum w
    vec2 P;         // sum w P, with P = p - p_o
    vec2 E;         // sum w E, with E = e - e_o, e = q - p
    vec3 PP;        // sum w P P^T as (xx, xy, yy); similarity, rigid: (its trace, 0, 0)
    vec4 PE;        // sum w P_i E_j as (11, 12, 21, 22); similarity, rigid: (11 + 22,
                    // 12 - 21, 0, 0) (mls_add_moments)
    MLSYardstick yard;   // for "coincident" sources (mls/weighting.glsl)
#if MLS_WEIGHT_NEXT
    float near2;    // the least squared distance a weight sees, where (d2 / m)^alpha is
                    // 2^-MLS_NEAR_BITS: the nearest's weight at most 2^100 (idw
                    // interpolating), e^60 2^30 (gaussian interpolating), no 1 / 0
#endif
};

MLSAccum mls_begin(vec2 v, MLSNearest n) {
    MLSAccum a;
    a.v = v;
    a.hit = mls_snaps(n);
    a.o = n.h;
    // every handle within the snapping distance (v on a lone segment): no far one to scale
    // the weights by, and m = 3e38 overflowed the segment's J2 (NaN f); 1, the scaled unit
    float far = n.d2far < 1e30 ? n.d2far : 1.0;
    a.m = mls_normalisation(a.hit ? far : max(n.d2min, mls_hit2(n)));
    a.inv_m = 1.0 / a.m;
    a.sigma = mls_sigma(a.m);
#if MLS_WEIGHT_NEXT
    // idw, and any weight made interpolating, relative to the nearest handles apart from
    // the nearest one's place, not to the nearest: next to a handle with a large alpha the
    // others weigh (d / D)^(2 alpha) of it, below float32's range (1e-50 for alpha = 10 at
    // 0.05 px of handles 20 px apart), yet their moments about it decide M. The nearest's
    // weight is bounded (near2), which changes p* by far less than float32 shows.
    if (!a.hit && n.d2next < 3.0e38) {
        a.m = max(a.m, n.d2next);
        a.inv_m = 1.0 / a.m;
        a.sigma = mls_sigma(a.m);
    }
    a.near2 = a.m * exp2(-MLS_NEAR_BITS / u_alpha);
#endif
#if MLS_REACH_GAUSSIAN && MLS_SEGMENTS
    // relative to the nearest handles apart where the nearest is a point handle (whose own
    // moments about itself are 0, so the cap of its weight changes nothing); relative to a
    // nearest segment itself, whose spread along it counts: a cap would flatten it
    a.g = n.segment ? a.m : mls_gaussian_offset(a.m, n.d2next);
#elif MLS_REACH_GAUSSIAN
    a.g = mls_gaussian_offset(a.m, n.d2next);
#else
    a.g = a.m;
#endif
#if MLS_REACH_GAUSSIAN
    vec2 u = v - a.o.xy;
    a.twice_u = 2.0 * u;
    // g - |u|^2: where g is the nearest apart's d2, its excess about o as each handle's is
    // taken (mls_handle_weight), so that its weight is 1 to float32's rounding of P.(P - 2u);
    // g - |u|^2 from the two squares loses to rounding what far out (|u| ~ 3,000 R and
    // beyond) or at a tiny radius is larger than R^2 itself, and every weight under/overflowed
    // (g the nearest's own distance, where no handle lies farther apart or the nearest is
    // a segment's point: 0 exactly, which its two squares, however fused, need not give)
    vec2 P_next = n.pnext - a.o.xy;
    bool next = n.d2next < 3.0e38 && a.g == n.d2next;
    a.g_o = next ? dot(P_next, P_next - a.twice_u) : (a.g == n.d2min ? 0.0 : a.g - dot(u, u));
    // g >= |u|^2 (the nearest's own excess, -g_o, is <= 0): a tie within float32's rounding
    // (the middle of two handles) may round it below, which weighed the nearest e^-(|g_o|/R^2)
    a.g_o = max(a.g_o, 0.0);
#endif
    a.W = 0.0;
    a.P = vec2(0.0);
    a.E = vec2(0.0);
    a.PP = vec3(0.0);
    a.PE = vec4(0.0);
    a.yard = mls_yardstick_begin();
    return a;
}

// The weight at a.v of a handle at p, squared distance d2. The snapped handle (and duplicates
// of it) is left out: its weight is infinite and its p^ zero, see mls_finish.
float mls_handle_weight(MLSAccum a, vec2 p, float d2) {
#if MLS_WEIGHT_NEXT
    float seen = max(d2, a.near2);
#else
    float seen = d2;
#endif
    bool none = u_snap && d2 <= u_hit2;
#ifdef MLS_WEIGHT_FUNCTION64
    if (!none && mls_at_edge(d2)) {
        // near d = R: d2 exact in float64 (of float32 p and v), and the weight from it
        dvec2 dp64 = dvec2(p) - dvec2(a.v);
        return mls_weight_edge(dot(dp64, dp64), a.g, a.inv_m, a.sigma, seen);
    }
#endif
#if MLS_REACH_GAUSSIAN
    // d2 - g about the nearest handle o: |p - v|^2 = |P - u|^2 = |u|^2 + P.(P - 2u), with
    // P = p - p_o and u = v - p_o, so d2 - g = P.(P - 2u) - (g - |u|^2) (mls_weight_excess);
    // the rounding of u and of g - |u|^2 is the same for every handle (f at a point within
    // float32's spacing of v, a factor common to the weights)
    vec2 P = p - a.o.xy;
    vec2 Q = P - a.twice_u;
    float scale = dot(abs(P), abs(P) + abs(a.twice_u));
    float w = mls_weight_excess(mls_excess(dot(P, Q), scale, a.g_o), seen, a.inv_m);
#else
    float w = mls_weight_seen(d2, seen, a.g, a.inv_m, a.sigma);
#endif
    return none ? 0.0 : w;
}

// Add second moments (sum w P P^T as (xx, xy, yy), sum w P_i E_j as (11, 12, 21, 22)) to the
// sums. Similarity and rigid MLS use only their rotation-invariant parts, the trace of the
// first and D11 + D22, D12 - D21 of the second (mls_rotation_scale): those are kept in
// PP.x, PE.x and PE.y instead, 3 sums per handle instead of 7.
void mls_add_moments(inout MLSAccum a, vec3 PP, vec4 PE) {
#if MLS_TRANSFORM == 0
    a.PP += PP;
    a.PE += PE;
#else
    a.PP.x += PP.x + PP.z;
    a.PE.xy += vec2(PE.x + PE.w, PE.y - PE.z);
#endif
}

void mls_accumulate(inout MLSAccum a, vec4 h, bool use) {
    vec2 dp = h.xy - a.v;
    float d2 = dot(dp, dp);
    // An empty slot gets no weight (zeros: every term below is then 0).
    float w = use ? mls_handle_weight(a, h.xy, d2) : 0.0;
    // Moments about the nearest handle, not about the origin: the differences of nearby
    // float32 values are exact, the nearest handle (the heaviest) adds nothing to them, and
    // the central moments in mls_finish lose no digits where one handle dominates.
    vec2 P = h.xy - a.o.xy;
    vec2 E = (h.zw - h.xy) - (a.o.zw - a.o.xy);
    vec2 wP = w * P;
    a.W += w;
    a.P += wP;
    a.E += w * E;
#if MLS_TRANSFORM == 0
    a.PP += vec3(wP.x * P.x, wP.x * P.y, wP.y * P.y);
    a.PE += vec4(wP.x * E.x, wP.x * E.y, wP.y * E.x, wP.y * E.y);
#else
    // the same sums as mls_add_moments keeps, formed per handle
    a.PP.x += dot(wP, P);
    a.PE.xy += vec2(dot(wP, E), wP.x * E.y - wP.y * E.x);
#endif
    // the handles at the nearest one's place (P = 0) apart
    mls_yardstick_add(a.yard, any(notEqual(P, vec2(0.0))), w, d2);
}

MLSResult mls_finish(MLSAccum a) {
    mls_full_needed = false;
    vec2 v = a.v;
    bool hit = a.hit;
    if (!hit && !(a.W > 0.0)) {
        return mls_identity(v);   // no handle reaches v (or there are none)
    }
    vec2 pst = a.o.xy;
    vec2 est = a.o.zw - a.o.xy;
    if (!hit) {
        // p* = p_o + sum w P / W, e* likewise, and the moments about them
        vec2 dp = a.P / a.W;
        vec2 de = a.E / a.W;
        pst += dp;
        est += de;
        mls_add_moments(a, -vec3(a.P.x * dp.x, a.P.x * dp.y, a.P.y * dp.y),
                        -vec4(a.P.x * de.x, a.P.x * de.y, a.P.y * de.x, a.P.y * de.y));
    }
    // Snapped: p* = p_o and q* = q_o exactly, and the moments about them are the sums.
    vec3 A = a.PP;
    vec4 D = a.PE;
    float spread = mls_yardstick(a.yard);
    vec4 N;   // M - I
#if MLS_TRANSFORM == 0
    float mu = A.x + A.z;
    // A and D relative to mu (mu > 0 where used): the products below stay in float32's
    // range where the moments are tiny (next to a handle whose weight is steep)
    vec3 An = A / mu;
    vec4 Dn = D / mu;
    // The similarity solution, and a ridge toward it where A is nearly singular (fewer than 3
    // handles in reach, or handles on or near one line), as glmls.reference (_solve,
    // _ridge_matrix) and 3D: M = (A + g)^-1 (B + g M_sim), g = share u2 u2^T for A's small
    // eigenvalue e2 (An's trace is 1) and its unit eigenvector u2, share = c (1 - e2 / c)^2
    // below c = MLS_DEGENERATE_SHARE, else 0 (the exact affine fit). In N = M - I:
    // N = (A + g)^-1 (D + g N_sim). On a line that is N_sim; between, a smooth blend where
    // a threshold would tear the image.
    vec4 sim = mls_rotation_scale(mu, D, spread);
    float det = An.x * An.z - An.y * An.y;
    float gap = sqrt((An.x - An.z) * (An.x - An.z) + 4.0 * An.y * An.y);   // e1 - e2
    float e1 = 0.5 * (1.0 + gap);
    float e2 = max(det, 0.0) / e1;   // without the cancellation of (1 - gap) / 2
    float x = 1.0 - e2 / MLS_DEGENERATE_SHARE;
    // g = share u2 u2^T with u2 u2^T = (e1 I - A) / (e1 - e2); gap > 1 - 2c wherever x > 0
    vec3 G = x > 0.0 ? (MLS_DEGENERATE_SHARE * x * x / gap) * vec3(e1 - An.x, -An.y, e1 - An.z)
                     : vec3(0.0);
    vec3 L = An + G;
    vec4 R = Dn + vec4(G.x * sim.x + G.y * sim.z, G.x * sim.y + G.y * sim.w,
                       G.y * sim.x + G.z * sim.z, G.y * sim.y + G.z * sim.w);
    float detL = L.x * L.z - L.y * L.y;
    mls_full_needed = mu > 1e-13 * spread && e2 < MLS_FULL_SHARE;
    if (mu > 1e-13 * spread && detL > 0.0) {
        // N = L^-1 R, with L = [[l11, l12], [l12, l22]]
        vec2 r0 = vec2(L.z, -L.y) / detL;
        vec2 r1 = vec2(-L.y, L.x) / detL;
        N = vec4(r0.x * R.x + r0.y * R.z, r0.x * R.y + r0.y * R.w,
                 r1.x * R.x + r1.y * R.z, r1.x * R.y + r1.y * R.w);
    } else {
        // no handle spread about p* (one in reach, or coincident sources)
        N = sim;
    }
#else
    // the trace of A, and D11 + D22, D12 - D21 as (D.x + D.w, D.y - D.z) (mls_add_moments)
    N = mls_rotation_scale(A.x, vec4(D.xy, 0.0, 0.0), spread);
#endif

    // f(v) = q* + (v - p*) M = v + e* + (v - p*) N
    vec2 vp = v - pst;
    MLSResult r;
    r.M = N + vec4(1.0, 0.0, 0.0, 1.0);
    // The displacement on its own: added to v in float64 by the caller, the identity (e = 0,
    // so est = 0 and N = 0 exactly) returns v itself, not v rounded to float32.
    r.d = est + vec2(vp.x * N.x + vp.y * N.z, vp.x * N.y + vp.y * N.w);
    r.f = v + r.d;
    return r;
}
