// The distance weights of Table 1 of "Extensions to the MLS method for image deformation",
// one function per entry of glmls.core.weights.REGISTRY, named mls_weight_<name>: the
// registry defines MLS_WEIGHT_FUNCTION as the one in use. A new weight is one function here
// and one registry entry.
//
// Every function takes the squared distance d2 of a handle and the normalisation of the
// point: m, the squared distance of the nearest handle in use, inv_m = 1 / m, and sigma =
// s / m^alpha (idw only, MLS_WEIGHT_USES_S). A weight may be divided by any factor common to
// all handles at a point (MLS ignores it): they are scaled so that the largest is about 1,
// so that float32 neither overflows (idw, shepard near a handle, any weight of a huge R) nor
// underflows (gaussian far from every handle). Distances are scaled (see core.glsl); u_radius
// is R, scaled, which float32 may round to 0 (R far below a pixel) or to inf (R beyond ~1e38):
// both limits give finite weights (no handle but one on the point reaches it; flat weights).

// The radius weights' formulas in either precision T (float, double): the float32 functions
// below and their float64 versions mls_weight64_<name> (glmls.core.weights.Weight.edge64, at
// the end of this file) expand the same text.
#define MLS_CRESSMAN(T, t) max(T(0.0), (T(1.0) - (t)) / (T(1.0) + (t)))
#define MLS_SHEPARD(T, d, R, m, d2) ((d) < (R) ? (T(1.0) - (d) / (R)) * sqrt((m) / (d2)) : T(0.0))
#define MLS_LINEAR(T, t) max(T(0.0), T(1.0) - sqrt(t))

// d2 / R^2, bounded so that (1 - t) / (1 + t) stays finite; 0 on the point itself.
float mls_radius_ratio(float d2) {
    float R2 = u_radius * u_radius;
    return R2 > 0.0 ? min(d2 / R2, 1e30) : (d2 > 0.0 ? 1e30 : 0.0);
}

// 1 / (s + d^(2 alpha)), times s + m^alpha
float mls_weight_idw(float d2, float m, float inv_m, float sigma) {
    return (sigma + 1.0) / (sigma + mls_pow(d2 * inv_m));
}

// max(0, (R^2 - d^2) / (R^2 + d^2)) = max(0, (1 - t) / (1 + t)), t = d^2 / R^2
float mls_weight_cressman(float d2, float m, float inv_m, float sigma) {
    float t = mls_radius_ratio(d2);
    return MLS_CRESSMAN(float, t);
}

// max(0, (R - d) / (R d)), times sqrt(m)
float mls_weight_shepard(float d2, float m, float inv_m, float sigma) {
    float d = sqrt(d2);
    return MLS_SHEPARD(float, d, u_radius, m, d2);
}

// exp(-d^2 / R^2), divided by its value at squared distance m: the nearest handle's, or the
// gaussian offset g of a point (mls_gaussian_offset), where the handles nearer than g weigh
// more than 1, at most e^MLS_GAUSSIAN_CAP (sums of a few stay in float32's range; the capped
// weights outweigh the rest by so much that the cap changes no digit of their moments), as
// glmls.core.weights.gaussian_excess
#ifndef MLS_GAUSSIAN_CAP
#define MLS_GAUSSIAN_CAP 60.0   // glmls.core.weights.GAUSSIAN_CAP
#endif
// The same from the excess x = d^2 - g alone: mls/core.glsl and mls3/core.glsl compute it
// more precisely than d^2 itself far from the handles (mls_handle_weight)
float mls_gaussian_excess(float x) {
    float t = mls_radius_ratio(abs(x));
    return exp(x < 0.0 ? min(t, MLS_GAUSSIAN_CAP) : -t);
}
float mls_weight_gaussian(float d2, float m, float inv_m, float sigma) {
    return mls_gaussian_excess(d2 - m);
}

// max(0, R - d), divided by R
float mls_weight_linear(float d2, float m, float inv_m, float sigma) {
    return MLS_LINEAR(float, mls_radius_ratio(d2));
}

// The slopes dw/d(d2) of the functions above, mls_slope_<name>(d2, w, m, inv_m, sigma) with
// w = mls_weight_<name>(d2, m, inv_m, sigma): the 3D Jacobian's derivative of the moments
// (mls3/core.glsl, mls3_eval_jacobian). A weight of the registry with ``slope=True`` has one
// (glmls.core.weights.Weight.slope); mls/weighting.glsl differentiates any other numerically.
float mls_slope_idw(float d2, float w, float m, float inv_m, float sigma) {
    // d/d(d2) (sigma + 1) / (sigma + r^alpha), r = d2 / m: -w alpha r^alpha / ((sigma + r^alpha) d2)
    float ra = mls_pow(d2 * inv_m);
    return d2 > 0.0 ? -w * u_alpha * (ra / (sigma + ra)) / d2 : 0.0;
}

float mls_slope_cressman(float d2, float w, float m, float inv_m, float sigma) {
    float R2 = u_radius * u_radius;
    float t = mls_radius_ratio(d2);
    return t < 1.0 && R2 > 0.0 ? -2.0 / ((1.0 + t) * (1.0 + t) * R2) : 0.0;
}

float mls_slope_shepard(float d2, float w, float m, float inv_m, float sigma) {
    // sqrt(m) (1 / d - 1 / R): -sqrt(m) / (2 d^3)
    float d = sqrt(d2);
    return d < u_radius && d > 0.0 ? -0.5 * sqrt(m) / (d2 * d) : 0.0;
}

// exp(-x / R^2) of the excess x = d2 - g: -w / R^2, 0 where the cap holds it
float mls_gaussian_excess_slope(float x, float w) {
    float R2 = u_radius * u_radius;
    bool capped = x < 0.0 && mls_radius_ratio(-x) >= MLS_GAUSSIAN_CAP;
    return capped || !(R2 > 0.0) ? 0.0 : -w / R2;
}
float mls_slope_gaussian(float d2, float w, float m, float inv_m, float sigma) {
    return mls_gaussian_excess_slope(d2 - m, w);
}

float mls_slope_linear(float d2, float w, float m, float inv_m, float sigma) {
    // 1 - sqrt(t): -1 / (2 sqrt(t) R^2) = -1 / (2 d R)
    float d = sqrt(d2);
    return d < u_radius && d > 0.0 ? -0.5 / (d * u_radius) : 0.0;
}

// The float64 versions, of a squared distance d2 exact in float64 (mls/weighting.glsl,
// mls_weight_edge): near d = R a radius weight is a difference of nearly equal numbers, and
// float32's rounding of d2 and of 1 - t is most of the weight there. R is float32's u_radius.
#ifdef MLS_WEIGHT_FUNCTION64
double mls_radius_ratio64(double d2) {
    double R2 = double(u_radius) * double(u_radius);
    return R2 > 0.0lf ? min(d2 / R2, 1e30lf) : (d2 > 0.0lf ? 1e30lf : 0.0lf);
}

double mls_weight64_cressman(double d2, float m, float inv_m, float sigma) {
    double t = mls_radius_ratio64(d2);
    return MLS_CRESSMAN(double, t);
}

double mls_weight64_shepard(double d2, float m, float inv_m, float sigma) {
    double d = sqrt(d2);
    return MLS_SHEPARD(double, d, double(u_radius), double(m), d2);
}

double mls_weight64_linear(double d2, float m, float inv_m, float sigma) {
    return MLS_LINEAR(double, mls_radius_ratio64(d2));
}
#endif
