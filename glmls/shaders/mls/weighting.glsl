// The weight of a handle at a squared distance, whatever the dimension: the uniforms of the
// weights (glmls.engine.kernel.weight_uniforms), the weights of mls/weights.glsl and
// ``interpolating``. Included by mls/core.glsl (2D) and mls3/core.glsl (3D).
//
// Defines: MLS_WEIGHT_FUNCTION, MLS_INTERPOLATING, MLS_ALPHA_ONE (see mls/core.glsl).

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

#ifndef MLS_REACH_GAUSSIAN
#define MLS_REACH_GAUSSIAN 0   // 1: the weight is the gaussian (glmls.core.weights support)
#endif
#if MLS_REACH_GAUSSIAN
// How far the gaussian's exponent at squared distance d2 is beyond the nearest handle's (m):
// above MLS_GAUSSIAN_NEGLIGIBLE, ln(1 / tau), the handle weighs less than tau of the nearest,
// in the tail float32 cannot compute (glmls.core.weights.gaussian_excess).
float mls_gaussian_excess(float d2, float m) {
    return mls_radius_ratio(max(d2 - m, 0.0));
}
#endif

// Weight of a handle at squared distance d2 (see mls/weights.glsl for m, inv_m and sigma).
float mls_weight(float d2, float m, float inv_m, float sigma) {
    float w = MLS_WEIGHT_FUNCTION(d2, m, inv_m, sigma);
#if MLS_INTERPOLATING
    w = w > 0.0 ? w / mls_pow(d2 * inv_m) : 0.0;   // 0, not 0/0, out of reach
#endif
    return w;
}

// The yardstick of "coincident sources" of one point, 2D and 3D (glmls.reference's
// _yardstick): sum w |p - v|^2 over the handles not at the nearest one's place, that sum
// over those at it added back where the weight is a gaussian and every other handle is in
// its tail. Next to a handle whose weight is steep (1 / d^(2 alpha), alpha > 1) its own
// w d2 grows without bound and would outweigh any spread of the others about p*, which
// decides M there (their power-law weights float32 computes to its precision); far in a
// gaussian's tail the others' weights are exp of large arguments that float32 cannot
// compute, and the nearest's w d2 keeps M = I unless their spread counts.
struct MLSYardstick {
    float spread;   // sum w |p - v|^2 over the handles not at p_o
#if MLS_REACH_GAUSSIAN
    float spread_o; // ... over those at p_o
    float excess;   // the least mls_gaussian_excess of the handles not at p_o in reach
#endif
};

MLSYardstick mls_yardstick_begin() {
    MLSYardstick y;
    y.spread = 0.0;
#if MLS_REACH_GAUSSIAN
    y.spread_o = 0.0;
    y.excess = 3.0e38;
#endif
    return y;
}

// A handle of weight w at squared distance d2, ``apart`` from the nearest one's place
// (P != 0); m, the point's normalisation distance.
void mls_yardstick_add(inout MLSYardstick y, bool apart, float w, float d2, float m) {
    float wd2 = w * d2;
    y.spread += apart ? wd2 : 0.0;
#if MLS_REACH_GAUSSIAN
    y.spread_o += apart ? 0.0 : wd2;
    y.excess = min(y.excess, apart && w > 0.0 ? mls_gaussian_excess(d2, m) : 3.0e38);
#endif
}

float mls_yardstick(MLSYardstick y) {
#if MLS_REACH_GAUSSIAN
    return y.spread + (y.excess > MLS_GAUSSIAN_NEGLIGIBLE ? y.spread_o : 0.0);
#else
    return y.spread;
#endif
}
