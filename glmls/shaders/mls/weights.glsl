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
    return max(0.0, (1.0 - t) / (1.0 + t));
}

// max(0, (R - d) / (R d)), times sqrt(m)
float mls_weight_shepard(float d2, float m, float inv_m, float sigma) {
    float d = sqrt(d2);
    return d < u_radius ? (1.0 - d / u_radius) * sqrt(m / d2) : 0.0;
}

// exp(-d^2 / R^2), divided by its value at squared distance m: the nearest handle's, or the
// gaussian offset g of a point (mls_gaussian_offset), where the handles nearer than g weigh
// more than 1, at most e^MLS_GAUSSIAN_CAP (sums of a few stay in float32's range; the capped
// weights outweigh the rest by so much that the cap changes no digit of their moments), as
// glmls.core.weights.gaussian_excess
#ifndef MLS_GAUSSIAN_CAP
#define MLS_GAUSSIAN_CAP 60.0   // glmls.core.weights.GAUSSIAN_CAP
#endif
float mls_weight_gaussian(float d2, float m, float inv_m, float sigma) {
    float t = mls_radius_ratio(abs(d2 - m));
    return exp(d2 < m ? min(t, MLS_GAUSSIAN_CAP) : -t);
}

// max(0, R - d), divided by R
float mls_weight_linear(float d2, float m, float inv_m, float sigma) {
    return max(0.0, 1.0 - sqrt(mls_radius_ratio(d2)));
}
