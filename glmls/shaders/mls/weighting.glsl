// The weight of a handle at a squared distance, whatever the dimension: the uniforms of the
// weights (glmls.engine.kernel.weight_uniforms), the weights of mls/weights.glsl and
// ``interpolating``. Included by mls/core.glsl (2D) and mls3/core.glsl (3D).
//
// Defines: MLS_WEIGHT_FUNCTION, MLS_INTERPOLATING, MLS_ALPHA_ONE (see mls/core.glsl).

#ifndef MLS_REACH_GAUSSIAN
#define MLS_REACH_GAUSSIAN 0   // 1: the weight is the gaussian (glmls.core.weights support)
#endif
#ifndef MLS_WEIGHT_RADIUS
#define MLS_WEIGHT_RADIUS 0    // 1: the weight is 0 from d = R on (glmls.core.weights support)
#endif
#ifndef MLS_WEIGHT_NEXT
// 1: idw or an interpolating weight without segments, relative to the nearest apart
// (mls/core.glsl, mls_begin)
#define MLS_WEIGHT_NEXT 0
#endif
// the least squared distance above the nearest's is tracked (mls_track_next)
#define MLS_TRACK_NEXT (MLS_REACH_GAUSSIAN || MLS_WEIGHT_NEXT)
// With MLS_WEIGHT_NEXT, the nearest's power (d2 / m)^-alpha is bounded at 2^MLS_NEAR_BITS:
// times the gaussian's cap (e^60, ~2^87) it stays within float32's 2^128 with room for sums
#if MLS_REACH_GAUSSIAN
#define MLS_NEAR_BITS 30.0
#else
#define MLS_NEAR_BITS 50.0
#endif

uniform float u_alpha;      // idw / interpolating power
#ifndef MLS_BATCH
#define MLS_BATCH 0   // 1: a batch's passes (mls/batch.glsl)
#endif
#if !MLS_BATCH  // a batch's passes set these per image (mls/batch.glsl)
uniform float u_log2_s;     // log2 of the scaled idw s; -1e30 when s == 0
uniform float u_radius;     // scaled influence radius R
uniform float u_hit2;       // squared snapping distance (scaled)
uniform bool u_snap;        // weight is (effectively) infinite at d = 0: f(p_i) = q_i exactly
#endif

float mls_pow(float r) {
#if MLS_ALPHA_ONE
    return r;
#else
    return r > 0.0 ? exp2(u_alpha * log2(r)) : 0.0;
#endif
}

#include "mls/weights.glsl"

// sigma = s / m^alpha (scaled, capped): idw's s at a point whose normalisation is m
// (mls/weights.glsl); 0 for the weights without s.
float mls_sigma(float m) {
#if MLS_WEIGHT_USES_S
    return min(exp2(u_log2_s - u_alpha * log2(m)), 1e30);
#else
    return 0.0;
#endif
}

// The normalisation m of a point whose nearest handle in use is at squared distance d2near.
// idw (not interpolating) is 1 / (s + d^(2 alpha)): where s exceeds d2near^alpha, m is
// s^(1/alpha) (bounded), so that sigma = s / m^alpha stays <= 1 and below mls_sigma's cap; a
// capped sigma made the weights (sigma + 1) / (sigma + (d2 / m)^alpha) fall off where s keeps
// them flat (the handles within s^(1/(2 alpha)) weigh alike).
float mls_normalisation(float d2near) {
#if MLS_WEIGHT_USES_S && !MLS_INTERPOLATING
    return max(d2near, min(exp2(u_log2_s / u_alpha), 1e30));
#else
    return d2near;
#endif
}

// The least squared distance above the nearest's (d2next), with a handle at squared distance
// d2 seen before the nearest's (d2min) takes it: the gaussian's offset (below). Nothing
// without the gaussian.
void mls_track_next(inout float d2next, float d2min, float d2) {
#if MLS_TRACK_NEXT
    d2next = d2 < d2min ? d2min : (d2 > d2min ? min(d2next, d2) : d2next);
#endif
}

// The gaussian's weights at a point are taken relative to those of the nearest handles apart
// from the nearest one's place (squared distance d2next, the least above the nearest's): in
// a gaussian's far tail the nearest outweighs them by e^30 and more, yet their moments about
// the nearest decide M, and relative to the nearest their weights would underflow float32
// (from ~e^-87). With no handle apart (d2next = 3e38), relative to the nearest, m.
float mls_gaussian_offset(float m, float d2next) {
    return d2next < 3.0e38 ? max(d2next, m) : m;
}

// Weight w of a handle at squared distance d2 made interpolating (MLS_INTERPOLATING): divided
// by (d2 / m)^alpha; 0, not 0/0, out of reach.
float mls_interpolated(float w, float d2, float inv_m) {
#if MLS_INTERPOLATING
    return w > 0.0 ? w / mls_pow(d2 * inv_m) : 0.0;
#else
    return w;
#endif
}

// Weight of a handle at squared distance d2 (see mls/weights.glsl for m, inv_m and sigma).
float mls_weight(float d2, float m, float inv_m, float sigma) {
    return mls_interpolated(MLS_WEIGHT_FUNCTION(d2, m, inv_m, sigma), d2, inv_m);
}

// The squared distance a weight's function takes where MLS_WEIGHT_NEXT bounds the nearest's
// weight, ``seen`` = max(d2, near2) (mls/core.glsl, mls_begin): the bound is for the powers
// (d2 / m)^alpha, idw's own and the interpolating factor; a weight with a reach takes d2
// itself, as near2 (a share of the next handle's distance) may lie past R: with the next
// handle far and alpha large it left out the one handle in reach (f = v there).
float mls_function_d2(float d2, float seen) {
#if MLS_WEIGHT_RADIUS
    return d2;
#else
    return seen;
#endif
}

// Weight of a handle at squared distance d2 that the powers see at ``seen`` (above).
float mls_weight_seen(float d2, float seen, float m, float inv_m, float sigma) {
    float w = MLS_WEIGHT_FUNCTION(mls_function_d2(d2, seen), m, inv_m, sigma);
    return mls_interpolated(w, seen, inv_m);
}

// The slope dw/d(d2) of the weight function MLS_SLOPE_FUNCTION (mls/weights.glsl) where the
// registry gives one; else a central difference of the function over a relative step of d2
// (a weight added without its slope): 2^-8, where the difference's O(step^2) error and its
// float32 rounding, ~eps32 / step, are about equal (~1e-5 of the slope).
#ifndef MLS_SLOPE_FUNCTION
#define MLS_SLOPE_FUNCTION mls_slope_numeric
float mls_slope_numeric(float d2, float w, float m, float inv_m, float sigma) {
    float h = max(d2, 1e-30) * 0.00390625;
    float high = d2 + h;
    float low = max(d2 - h, 0.0);
    float up = MLS_WEIGHT_FUNCTION(high, m, inv_m, sigma);
    return (up - MLS_WEIGHT_FUNCTION(low, m, inv_m, sigma)) / (high - low);
}
#endif

// The slope of ``interpolating``'s w / r^alpha (r = d2 / m) from the weight function's value
// ``raw`` and slope at d2: slope / r^alpha - alpha w / d2 (0 out of reach).
float mls_interpolated_slope(float raw, float slope, float d2, float inv_m) {
#if MLS_INTERPOLATING
    return raw > 0.0 && d2 > 0.0
        ? slope / mls_pow(d2 * inv_m) - u_alpha * mls_interpolated(raw, d2, inv_m) / d2 : 0.0;
#else
    return slope;
#endif
}

#if MLS_REACH_GAUSSIAN
// The gaussian's weight of a handle whose excess d2 - g over the point's offset g is known
// apart from its squared distance d2 (mls/core.glsl, mls_handle_weight: far from every
// handle d2 and g are ~D^2 while the weights that count differ by a few R^2 from g, and their
// float32 roundings, ~6e-8 D^2 each and different for every handle, would move the weights;
// the excess taken about the nearest handle is rounded at ~6e-8 D |p - p_o| instead). seen:
// d2 as mls_weight takes it, for the interpolating factor.
float mls_weight_excess(float excess, float seen, float inv_m) {
    return mls_interpolated(mls_gaussian_excess(excess), seen, inv_m);
}

// The excess P.Q - g_o of a handle at P about the nearest (Q = P - 2u), 0 where it lies
// within float32's rounding of its terms (MLS_EXCESS_ULPS steps of |P|.(|P| + |2u|) +
// |g_o|: Q's own rounding is that of its operands, however much they cancel, as at the
// middle of two handles): the nearest apart's, whose excess g_o is by definition, is 0
// however the compiler fused the two dot products, where at a tiny radius (R^2 ~ 1e-8 px^2)
// their rounding, divided by R^2, took its weight to e^-2000 and f to a bare translation.
// ``pq`` = P.Q, ``scale`` = |P|.(|P| + |2u|) taken componentwise.
#define MLS_EXCESS_ULPS 4.0
float mls_excess(float pq, float scale, float g_o) {
    float x = pq - g_o;
    return abs(x) <= MLS_EXCESS_ULPS * 1.1920929e-7 * (scale + abs(g_o)) ? 0.0 : x;
}
#endif

// The radius weights at the edge of their reach (MLS_WEIGHT_FUNCTION64 is defined for a
// weight with glmls.core.weights.Weight.edge64): near d = R the weight is a difference of
// nearly equal numbers, 1 - d2 / R^2, where float32's rounding of d2 (~1e-7 R^2) is most of
// it, and a handle whose weight tends to 0 may decide what the others leave free (f is steep
// there: docs/mathematics.md). A handle whose float32 d2 lies within MLS_EDGE_BAND R^2 of R^2
// takes its d2, its reach and its weight in float64 (mls_weight_edge); only those pay.
#ifdef MLS_WEIGHT_FUNCTION64
#define MLS_EDGE_BAND 5e-3
bool mls_at_edge(float d2) {
    float R2 = u_radius * u_radius;
    // R2 rounded to 0 or beyond float32's range: no edge for float64 to place better
    return R2 > 0.0 && R2 < 1e30 && abs(d2 - R2) <= MLS_EDGE_BAND * R2;
}

// mls_weight of a handle at squared distance d2, exact in float64; seen: the float32 d2 that
// mls_weight would take (d2, or at least the near2 of mls/core.glsl's mls_begin), for the
// interpolating factor (d2 / m)^alpha, which float32 keeps to its precision. The weight's
// own rounding to float32 is then ~6e-8 of it.
float mls_weight_edge(double d2, float m, float inv_m, float sigma, float seen) {
    return mls_interpolated(float(MLS_WEIGHT_FUNCTION64(d2, m, inv_m, sigma)), seen, inv_m);
}
#endif

// The yardstick of "coincident sources" of one point, 2D and 3D (glmls.reference's
// _yardstick): sum w |p - v|^2 over the handles not at the nearest one's place. The
// nearest's own w d2 is left out: next to a handle whose weight is steep (1 / d^(2 alpha),
// alpha > 1) it grows without bound, and in a gaussian's far tail it outweighs the others by
// e^30 and more, yet the others' spread about p* decides M in both places (the moments are
// taken about the nearest handle, which adds nothing to them, so float32 keeps the others'
// small weights to its precision until they underflow).
struct MLSYardstick {
    float spread;   // sum w |p - v|^2 over the handles not at p_o
};

MLSYardstick mls_yardstick_begin() {
    MLSYardstick y;
    y.spread = 0.0;
    return y;
}

// A handle of weight w at squared distance d2, ``apart`` from the nearest one's place
// (P != 0).
void mls_yardstick_add(inout MLSYardstick y, bool apart, float w, float d2) {
    y.spread += apart ? w * d2 : 0.0;
}

float mls_yardstick(MLSYardstick y) {
    return y.spread;
}
