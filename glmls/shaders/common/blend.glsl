// a blended with b by t in [0, 1], as a (1 - t) + b t: GLSL's mix(a, b, t) = a + t (b - a)
// overflows float32 where a and b have opposite signs beyond half its range (2e38 next to
// -2e38 gives -inf, then NaN), while both products here stay within |a| and |b|. Exact at
// t = 0 (a) and t = 1 (b) for finite values.
vec4 sample_blend(vec4 a, vec4 b, float t) {
    return a * (1.0 - t) + b * t;
}
