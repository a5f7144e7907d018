// a blended with b by t in [0, 1], as a (1 - t) + b t: GLSL's mix(a, b, t) = a + t (b - a)
// overflows float32 where a and b have opposite signs beyond half its range (2e38 next to
// -2e38 gives -inf, then NaN), while both products here stay within |a| and |b|. a itself
// where t is 0 and b where t is 1, so that a NaN or infinite value of weight 0 does not make
// the result NaN (0 * inf, 0 * NaN): a sample on a pixel centre's row or column takes only
// that row's or column's pixels.
vec4 sample_blend(vec4 a, vec4 b, float t) {
    return t == 0.0 ? a : (t == 1.0 ? b : a * (1.0 - t) + b * t);
}
