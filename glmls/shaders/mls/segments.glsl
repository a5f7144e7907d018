// Line-segment handles (Schaefer, McPhail & Warren 2006, section 4), added to the point
// handles' moments of mls/core.glsl. Included by mls/visit.glsl where MLS_SEGMENTS is 1.
//
// Segment s is two rows of the handle storage (mls/handles.glsl) from u_segment_offset + 2 s:
// (a.x, a.y, b.x, b.y), the source from a to b, and (c.x, c.y, d.x, d.y), the target.
// p(x) = f + x u and q(x) = q_f + x g, x the arc length along the source from the foot f of the
// perpendicular from v (u = (b - a) / L, g = (d - c) / L, L = |b - a|), so |p(x) - v|^2 =
// h^2 + x^2. Every sum over point handles becomes an integral over x of the weight times the
// same terms, and a segment adds to every moment through three integrals:
//   J_k = u_length_unit * integral over the segment of w(h^2 + x^2) (x - xc)^k dx,  k = 0, 1, 2
// about xc, the segment's point nearest to v: where the weight is largest, and where o, the
// point the moments are summed about (mls_accumulate), usually is. About the foot instead, a
// short arc far from it (the end of a segment at the edge of a compact weight's reach) would
// lose its spread to cancellation in float32.
// (u_length_unit: pixels per scaled unit, so that a segment's weight is per pixel of length,
// as in glmls.reference, whatever the scaling).
//
// Defines:
//   MLS_SEGMENT_CLOSED   1: idw, alpha 1, not interpolating: J_k in closed form
//                        0: Gauss-Legendre after the substitution x = c sinh(t), c ~ h, which
//                           turns the peak of the weight at the foot into a smooth bump
//                           (Johnston & Elliott 2005), in panels of width <= u_segment_panel_width
//   MLS_SEGMENT_SUPPORT  0 everywhere, 1 radius (w = 0 from d = R), 2 gaussian (cut where
//                        w < exp(-MLS_SEGMENT_GAUSSIAN_CUT) of the nearest handle's)
uniform int u_segment_count;
uniform int u_segment_offset;
uniform float u_length_unit;
uniform float u_segment_sigma;   // 1, or 0 where idw's s is negligible (glmls.core.segments)

// the panels' width in t (glmls.core.segments.segment_panel_width): 1.5, narrower for a steep
// weight, whose tail falls like e^(-(pole - 1) |t|)
uniform float u_segment_panel_width;
const float MLS_SEGMENT_WEIGHT_CAP = 1.2676506e30;   // 2^100: sums of a few stay finite
const int MLS_MAX_PANELS = 24;
// e^-80 of the nearest handle's weight: in a gaussian's far tail the handles apart from the
// nearest decide M however small their weights (mls/weights.glsl), so a segment there counts
// down to float32's range (a cut at e^-24 dropped a segment that decided M: f 1.5 px off)
const float MLS_SEGMENT_GAUSSIAN_CUT = 80.0;
// 8-point Gauss-Legendre nodes and weights on [-1, 1] (the positive half; symmetric)
const float MLS_GL_X[4] = float[4](0.1834346424956498, 0.5255324099163290,
                                   0.7966664774136267, 0.9602898564975363);
const float MLS_GL_W[4] = float[4](0.3626837833783620, 0.3137066458778873,
                                   0.2223810344533745, 0.1012285362903763);

struct MLSSegment {
    vec2 a;     // source start
    vec2 u;     // source direction, unit
    float L;    // source length
    vec2 c;     // target start
    vec2 g;     // target change per unit of source length: (d - c) / L
};

MLSSegment mls_segment(int s) {
    vec4 src = mls_handle(u_segment_offset + 2 * s);
    vec4 dst = mls_handle(u_segment_offset + 2 * s + 1);
    MLSSegment seg;
    vec2 ab = src.zw - src.xy;
    seg.a = src.xy;
    seg.L = length(ab);
    seg.u = ab / seg.L;
    seg.c = dst.xy;
    seg.g = (dst.zw - dst.xy) / seg.L;
    return seg;
}

// Where v sees a segment: x0 = arc coordinate of a (b is at x0 + L), h2 = squared distance to
// the segment's line, xc = the closest point's arc coordinate.
struct MLSSegmentView {
    float x0;
    float x1;
    float h;    // distance to the line
    float h2;
    float xc;
};

MLSSegmentView mls_segment_view(MLSSegment seg, vec2 v) {
    vec2 av = seg.a - v;
    MLSSegmentView view;
    view.x0 = dot(av, seg.u);
    view.x1 = view.x0 + seg.L;
    view.h = abs(av.x * seg.u.y - av.y * seg.u.x);   // cross product: precise for small h
    view.h2 = view.h * view.h;
    view.xc = clamp(0.0, view.x0, view.x1);
    return view;
}

// The nearest point of a segment for pass 1 (mls_nearest_add), as a handle (p, q).
void mls_nearest_add_segment(inout MLSNearest n, MLSSegment seg, vec2 v) {
    MLSSegmentView view = mls_segment_view(seg, v);
    float d2 = view.h2 + view.xc * view.xc;
    float t = view.xc - view.x0;   // arc length from a
    vec4 h = vec4(seg.a + t * seg.u, seg.c + t * seg.g);
    bool nearer = d2 < n.d2min;
    mls_nearest_next(n, d2, h.xy);
    n.h = nearer ? h : n.h;
    n.segment = nearer ? true : n.segment;
    n.d2min = min(n.d2min, d2);
    n.d2far = min(n.d2far, d2 > u_hit2_segments ? d2 : 3.0e38);
}

float mls_log1p(float y) {
    // log(1 + y) loses the digits of small y in float32
    return y < 0.0625 ? y * (1.0 - y * (0.5 - y * (1.0 / 3.0 - y * (0.25 - y * 0.2))))
                      : log(1.0 + y);
}

// asinh(z) without the cancellation of log(z + sqrt(z^2 + 1)) for z < 0 (the built-in may
// have it) or the lost digits of log(1 + y) for small z
float mls_asinh(float z) {
    float a = abs(z);
    return sign(z) * mls_log1p(a + a * a / (1.0 + sqrt(1.0 + a * a)));
}

// z - atan(z) for |z| < 0.25, by its series
float mls_z_minus_atan(float z) {
    float z2 = z * z;
    return z * z2 * (1.0 / 3.0 - z2 * (0.2 - z2 * (1.0 / 7.0 - z2 * (1.0 / 9.0 - z2 / 11.0))));
}

// atan(y / x) in [0, pi] for y >= 0, to a few float32 ulps: the built-in atan may be
// thousands of ulps off (GLSL does not bound it; llvmpipe's is ~30), and J0 needs it to a few.
// Reduced to |z| <= 1, then twice halved (atan z = 2 atan(z / (1 + sqrt(1 + z^2)))) to
// |z| <= tan(pi / 16), where its series to z^13 is exact to float32.
float mls_atan_positive(float y, float x) {
    float ay = abs(y), ax = abs(x);
    bool swap = ay > ax;
    // ay <= ax here, so 0 / 0 means 0 (not max(ax, 1e-38): a subnormal, flushed to 0 by
    // GPUs, gave 0 / 0 = NaN on NVIDIA at a segment's end)
    float z = swap ? ax / ay : (ax > 0.0 ? ay / ax : 0.0);
    z = z / (1.0 + sqrt(1.0 + z * z));
    z = z / (1.0 + sqrt(1.0 + z * z));
    float z2 = z * z;
    float s = z * (1.0 - z2 * (1.0 / 3.0 - z2 * (0.2 - z2 * (1.0 / 7.0 - z2 * (1.0 / 9.0
              - z2 * (1.0 / 11.0 - z2 / 13.0))))));
    float r = 4.0 * s;   // atan(min(ay, ax) / max(ay, ax)), in [0, pi / 4]
    r = swap ? 1.5707963267948966 - r : r;
    return x < 0.0 ? 3.141592653589793 - r : r;
}

#if MLS_SEGMENT_CLOSED
// idw, alpha = 1: w = (sigma + 1) / (sigma + d2 / m) = K / (s' + h^2 + x^2) with K = (sigma
// + 1) m and s' = sigma m; k2 = s' + h^2:
//   J0 = K dtheta / k,  J1 = K / 2 ln((k2 + x1^2) / (k2 + x0^2)),  J2 = K (x1 - x0 - k dtheta)
// with dtheta = atan(x1 / k) - atan(x0 / k) in one atan (no cancellation), and series where
// the segment is short against k (J1, J2 would cancel).
vec3 mls_segment_integrals(MLSAccum a, MLSSegment seg, MLSSegmentView view) {
    float sigma = a.sigma * u_segment_sigma;
    // (a.sigma + 1), not (sigma + 1): a segment leaves a negligible s out of its weight, not
    // out of the factor the point handles' weights carry (mls_weight_idw's sigma + 1)
    float K = (a.sigma + 1.0) * a.m;
    float k2 = sigma * a.m + view.h2;
    float k = sqrt(k2);
    float x0 = view.x0, x1 = view.x1;
    float dtheta = mls_atan_positive(k * (x1 - x0), k2 + x0 * x1);
    // k = 0: v on the segment's line (s negligible). Beyond the segment (x0, x1 of one sign)
    // J0 is dtheta / k's limit, 1 / x0 - 1 / x1 (dtheta is 0 there: J0 was 0, and f wrong by
    // pixels along the line); on it, v is snapped (J0 unused).
    float J0 = k > 0.0 ? dtheta / k : (x0 * x1 > 0.0 ? (x1 - x0) / (x0 * x1) : 0.0);
    float J1, J2;
    if (max(x0 * x0, x1 * x1) < 0.0625 * k2) {
        J1 = 0.5 * (mls_log1p(x1 * x1 / k2) - mls_log1p(x0 * x0 / k2));
        J2 = k * (mls_z_minus_atan(x1 / k) - mls_z_minus_atan(x0 / k));
    } else {
        J1 = 0.5 * (log(k2 + x1 * x1) - log(k2 + x0 * x0));
        J2 = (x1 - x0) - k * dtheta;
    }
    // about xc (0 where the foot is on the segment). Skipped at xc = 0, not only to save work:
    // at a snapped end (k = 0, x0 = 0) J1 is infinite (log 0), and 0 * inf would be NaN
    // (NVIDIA's log(0) is -inf; llvmpipe forgave it).
    float xc = view.xc;
    if (abs(xc) > x1 - x0) {
        // the foot beyond the segment by more than its length: J2 - 2 xc J1 + xc^2 J0 would
        // cancel to ~L^3 / xc^2 from terms ~L (a short segment far away: its spread, all
        // that a lone segment says of a rotation, lost in float32). There the weight is
        // smooth over the segment (its peak at least |xc| away): Gauss-Legendre in y = x - xc.
        float half_length = 0.5 * (x1 - x0);
        float mid = xc > 0.0 ? half_length : -half_length;   // y from 0 to L, or -L to 0
        vec3 J = vec3(0.0);
        for (int j = 0; j < 8; ++j) {
            float node = (j < 4 ? -MLS_GL_X[3 - j] : MLS_GL_X[j - 4]);
            float gw = (j < 4 ? MLS_GL_W[3 - j] : MLS_GL_W[j - 4]);
            float y = mid + half_length * node;
            float x = xc + y;
            J += gw / (k2 + x * x) * vec3(1.0, y, y * y);
        }
        return K * u_length_unit * half_length * J;
    }
    if (xc != 0.0) {
        J2 = J2 - 2.0 * xc * J1 + xc * xc * J0;
        J1 = J1 - xc * J0;
    }
    return K * u_length_unit * vec3(J0, J1, J2);
}
#else
vec3 mls_segment_integrals(MLSAccum a, MLSSegment seg, MLSSegmentView view) {
    float x0 = view.x0, x1 = view.x1;
#if MLS_SEGMENT_SUPPORT == 1
    float reach2 = (u_radius - view.h) * (u_radius + view.h);   // no cancellation at h ~ R
#elif MLS_SEGMENT_SUPPORT == 2
    float reach2 = a.g + MLS_SEGMENT_GAUSSIAN_CUT * u_radius * u_radius - view.h2;
#endif
#if MLS_SEGMENT_SUPPORT != 0
    if (!(reach2 > 0.0)) {
        return vec3(0.0);
    }
    float reach = sqrt(reach2);
    x0 = clamp(x0, -reach, reach);
    x1 = clamp(x1, -reach, reach);
#endif
    // the peak's width: h, or R where the weight is narrower than that (a gaussian far away)
#if MLS_SEGMENT_SUPPORT == 0
    float c = max(view.h, sqrt(u_hit2_segments));
#else
    float c = max(min(view.h, u_radius), sqrt(u_hit2_segments));
#endif
#if MLS_SEGMENT_SUPPORT == 2
    // a segment beyond the foot: the gaussian falls from its near end xs within
    // R^2 / (2 |xs|), a sliver of a width of R or h once |xs| exceeds R (at 10 R, 1 / 20 of
    // it, where 8 nodes of a panel about the foot gave p* 0.1 px off): x = xs + c sinh(t)
    // about the near end, of that width
    float xs = clamp(0.0, x0, x1);
    c = xs != 0.0 ? max(min(c, u_radius * u_radius / (2.0 * abs(xs))), sqrt(u_hit2_segments))
                  : c;
    // the nodes' excess d^2 - g about the nearest handle o, as mls_handle_weight takes a
    // point handle's: far from every handle d^2 and g are ~D^2, the weights that count differ
    // by a few R^2 from g, and the rounding of h^2 + x^2 (~6e-8 D^2, different at every
    // node and segment) moved f by up to 0.3 px 60 R out. A node's P = p(x) - p_o is the
    // segment's start about o and its arc length from the start, xs - x0 (0, L or -x0: the
    // near end, the far one, the foot) plus the node's dx.
    vec2 start = seg.a - a.o.xy;
    float from_start = x0 >= 0.0 ? 0.0 : (x1 <= 0.0 ? seg.L : -view.x0);
#else
    const float xs = 0.0;
#endif
    float sigma = a.sigma * u_segment_sigma;
    // the point handles' factor sigma + 1 where the segment leaves s out (see above)
    float carried = (a.sigma + 1.0) / (sigma + 1.0);
    // without s a weight is infinite at the segment, and m may lie far above h^2 (idw's
    // normalisation by s, mls_normalisation): the least squared distance a weight sees,
    // where (d2 / m)^alpha is 2^-100, keeps it finite (an overflow made f NaN within
    // ~0.005 px of a segment at alpha 10). The point handles weigh 2^-90 of it and less
    // there, as they are negligible against the segment's true weight. A weight made
    // interpolating divides by (d2 / m)^alpha once more (idw's would reach 2^200, beyond
    // float32, and the snapped segment's J2 with it): the weight itself is bounded at 2^100.
    float near2 = a.m * exp2(-100.0 / u_alpha);
    float t0 = mls_asinh((x0 - xs) / c);
    float t1 = mls_asinh((x1 - xs) / c);
    int panels = clamp(int(ceil((t1 - t0) / u_segment_panel_width)), 1, MLS_MAX_PANELS);
    float half_width = 0.5 * (t1 - t0) / float(panels);
    vec3 J = vec3(0.0);
    for (int k = 0; k < panels; ++k) {
        float mid = t0 + (2.0 * float(k) + 1.0) * half_width;
        for (int j = 0; j < 8; ++j) {
            float node = (j < 4 ? -MLS_GL_X[3 - j] : MLS_GL_X[j - 4]);
            float gw = (j < 4 ? MLS_GL_W[3 - j] : MLS_GL_W[j - 4]);
            float e = exp(mid + half_width * node);
            float dx = c * 0.5 * (e - 1.0 / e);   // c sinh(t), and c cosh(t) below
            float x = xs + dx;
            float d2 = view.h2 + x * x;
            float seen = max(d2, near2);
#if MLS_SEGMENT_SUPPORT == 2
            vec2 P = start + (from_start + dx) * seg.u;
            vec2 Q = P - a.twice_u;
            float scale = dot(abs(P), abs(P) + abs(a.twice_u));
            float excess = mls_excess(dot(P, Q), scale, a.g_o);
            float raw = mls_weight_excess(excess, seen, a.inv_m);
#else
            float raw = mls_weight_seen(d2, seen, a.g, a.inv_m, sigma);
#endif
            float w = min(raw, MLS_SEGMENT_WEIGHT_CAP) * gw * c * 0.5 * (e + 1.0 / e);
            float y = (xs - view.xc) + dx;   // not x - xc: xs may be far from the foot
            J += w * vec3(1.0, y, y * y);
        }
    }
    return (carried * half_width * u_length_unit) * J;
}
#endif

// Add segment seg's moments about the nearest handle a.o (see mls_accumulate). On a snapped
// segment (v within the snapping distance, weight infinite there) J0 and J1 are infinite or
// dominated: p* is the foot (a.o), and the segment adds only its second moment about it.
// J_k are about the segment's nearest point: P and E below are that point's.
void mls_accumulate_segment(inout MLSAccum a, MLSSegment seg) {
    MLSSegmentView view = mls_segment_view(seg, a.v);
    vec3 J = mls_segment_integrals(a, seg, view);
    float d2 = view.h2 + view.xc * view.xc;
    bool snapped = u_snap_segments && d2 <= u_hit2_segments;
    float J0 = snapped ? 0.0 : J.x;
    float J1 = snapped ? 0.0 : J.y;
    float J2 = J.z;
    vec2 u = seg.u;
    vec2 du = seg.g - seg.u;   // the displacement's change per unit length
    // the segment's nearest point (at xc) and its displacement, about the nearest handle
    float xa = view.xc - view.x0;   // its arc length from a
    vec2 P = (seg.a - a.o.xy) + xa * u;
    vec2 E = (seg.c - seg.a) + xa * du - (a.o.zw - a.o.xy);
    a.W += J0;
    a.P += J0 * P + J1 * u;
    a.E += J0 * E + J1 * du;
    mls_add_moments(a,
        J0 * vec3(P.x * P.x, P.x * P.y, P.y * P.y)
            + J1 * vec3(2.0 * P.x * u.x, P.x * u.y + u.x * P.y, 2.0 * P.y * u.y)
            + J2 * vec3(u.x * u.x, u.x * u.y, u.y * u.y),
        J0 * vec4(P.x * E.x, P.x * E.y, P.y * E.x, P.y * E.y)
            + J1 * vec4(P.x * du.x + u.x * E.x, P.x * du.y + u.x * E.y,
                        P.y * du.x + u.y * E.x, P.y * du.y + u.y * E.y)
            + J2 * vec4(u.x * du.x, u.x * du.y, u.y * du.x, u.y * du.y));
    a.yard.spread += (view.h2 + view.xc * view.xc) * J0 + 2.0 * view.xc * J1 + J2;
}
