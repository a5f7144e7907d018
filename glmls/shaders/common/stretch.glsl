// How many times f magnifies lengths at a point s, from differences of f (2D: warp/newton.glsl's
// warp_accepted; 3D: volume/newton.comp.glsl's second pass; the host's
// glmls.imaging.inverse.stretch_at alike): along each axis the shorter of the differences of
// a step h on its two sides, the longest axis's, where f is smooth on every side (else, or
// not finite, 1). A side is smooth where halving the step halves the difference (within a
// quarter): a jump of f (where a compact weight's reach ends) within the step does not
// shrink with it, whether it lies on one side of s or, in a sliver between two reaches'
// edges, on both.
//
// The caller evaluates f at stretch_point(s, k, h), k = 0 .. stretch_evaluations(dim) - 1 (s,
// then s + h, s + h / 2, s - h and s - h / 2 along x, then y, then z), in that order, and
// hands each value to stretch_take: one evaluation at a time, so that it can run them
// through its own single evaluation of f. Points and values are vec3 (z = 0 in 2D).

int stretch_evaluations(int dim) {
    return 1 + 4 * dim;
}

vec3 stretch_point(vec3 s, int k, float h) {
    int j = k - 1;
    vec3 along = vec3(equal(ivec3(j / 4), ivec3(0, 1, 2)));
    float step = (j % 2 == 1 ? 0.5 : 1.0) * ((j / 2) % 2 == 1 ? -1.0 : 1.0) * h;
    return k == 0 ? s : s + step * along;
}

struct StretchMeasure {
    vec3 fs;       // f(s)
    float full;    // the difference of the whole step on the side measured
    vec3 least;    // per axis, the shorter side's difference so far (0 past the dimension)
    bool halves;   // every side measured halves its difference with the step
};

StretchMeasure stretch_begin(int dim) {
    StretchMeasure m;
    m.fs = vec3(0.0);
    m.full = 0.0;
    m.least = vec3(3.0e38, 3.0e38, dim == 3 ? 3.0e38 : 0.0);
    m.halves = true;
    return m;
}

// m with f at stretch_point(s, k, h).
void stretch_take(inout StretchMeasure m, int k, vec3 f) {
    if (k == 0) {
        m.fs = f;
    } else if (k % 2 == 1) {
        m.full = length(f - m.fs);
        int axis = (k - 1) / 4;
        m.least[axis] = min(m.least[axis], m.full);
    } else {
        m.halves = m.halves && abs(m.full - 2.0 * length(f - m.fs)) <= 0.25 * m.full;
    }
}

// The stretch of a measure every evaluation of which was taken, with step h.
float stretch_of(StretchMeasure m, float h) {
    float stretch = m.halves ? max(m.least.x, max(m.least.y, m.least.z)) / h : 1.0;
    return stretch < 3.0e38 ? stretch : 1.0;
}
