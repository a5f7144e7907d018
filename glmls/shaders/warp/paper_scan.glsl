// The scan of one square of method "paper-quads" (glmls.core.paper_quads is the float64
// reference, whose rules this follows), shared by a single image's scan
// (warp/paper_quads.comp.glsl) and a batch's (batch/paper_quads.comp.glsl), so that both give
// the same keys and source points: Q = f at the square's vertices, the pixel centres P in Q's
// bounding rectangle that are inside Q (crossing number of a ray towards +x, or within
// PAPER_TOLERANCE of an edge) get the key ~(4 k + v) with atomicMax (k the square's scan
// index in the whole lattice, v its vertex nearest to P in the order 00, 10, 11, 01), so the
// smallest k wins whatever order the invocations run in; WARP_PAPER_STAGE 1 (linear) writes,
// at the pixels the square won, the source point of P under the inverse of Q's bilinear map.
//
// The winner buffer and the map are an atlas of output canvases stacked top to bottom
// (a single image's is the one canvas): image ``image``'s pixel (x, y) is row
// image * H + y. The includer's main finds a square's four output points and calls
// paper_scan with them.
// a large square is walked in pieces on llvmpipe; a pixel runs the loops over the square's
// vertices (4) and the roots (2) besides its own step
#define SCAN_PIECE_COST 8
#include "common/pieces.glsl"

layout(std430, binding = BIND_WINNER) buffer WarpWinner {
    uint warp_winner[];   // per atlas pixel, row-major: ~(4 k + v) of the winner, 0 = none
};
#if WARP_PAPER_STAGE == 1
layout(rgba32f, binding = BIND_INVERSE_MAP) writeonly uniform image2D u_map;
#endif

uniform ivec2 u_target_size;      // W, H of one output canvas in pixels
uniform ivec2 u_lattice_offset;   // the source pixel of lattice point (0, 0)

// Is p within PAPER_TOLERANCE of the segment a -> b (a point where a == b)?
bool near_edge(vec2 a, vec2 b, vec2 p) {
    vec2 d = b - a;
    float length2 = dot(d, d);
    float t = length2 > 0.0 ? clamp(dot(p - a, d) / length2, 0.0, 1.0) : 0.0;
    vec2 e = a + t * d - p;
    return dot(e, e) <= PAPER_TOLERANCE * PAPER_TOLERANCE;
}

// Does the ray from p towards +x cross the edge a -> b (half-open in y)?
bool crosses(vec2 a, vec2 b, vec2 p) {
    if ((a.y > p.y) == (b.y > p.y)) {
        return false;
    }
    return p.x < a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y);
}

#if WARP_PAPER_STAGE == 1
float cross2(vec2 a, vec2 b) {
    return a.x * b.y - a.y * b.x;
}

// (a, b) in [0, 1]^2 with Q(a, b) = p for the bilinear map Q(a, b) = q00 + a (q10 - q00) +
// b (q01 - q00) + a b (q00 - q10 + q11 - q01); of two roots the one inside the square (a
// folded Q may have none: the nearest, clamped).
vec2 inverse_bilinear(vec2 q00, vec2 q10, vec2 q11, vec2 q01, vec2 p) {
    vec2 e = q10 - q00;
    vec2 f = q01 - q00;
    vec2 g = q00 - q10 + q11 - q01;
    vec2 h = p - q00;
    float k2 = cross2(g, f);
    float k1 = cross2(e, f) + cross2(h, g);
    float k0 = cross2(h, e);
    // the roots of k2 b^2 + k1 b + k0 without cancellation: t = -(k1 + sign(k1) w) / 2 and
    // b = k0 / t, t / k2. Where Q is a parallelogram up to float32 rounding (k2 ~ 1e-6 k1:
    // every affine map) the first is -k0 / k1 to rounding and the second far outside the
    // square (infinite where k2 = 0); the textbook (-k1 + w) / (2 k2) loses there all but
    // a few bits of b to the difference of two nearly equal numbers.
    float w = sqrt(max(k1 * k1 - 4.0 * k0 * k2, 0.0));
    float t = -0.5 * (k1 + (k1 < 0.0 ? -w : w));
    vec2 roots = vec2(k0 / t, t / k2);
    vec2 best = vec2(0.0);
    float best_miss = 1e30;
    for (int r = 0; r < 2; ++r) {
        float b = roots[r];
        vec2 den = e + g * b;
        float a = abs(den.x) > abs(den.y) ? (h.x - f.x * b) / den.x : (h.y - f.y * b) / den.y;
        vec2 ab = vec2(a, b);
        bool finite = !(isnan(a) || isinf(a) || isnan(b) || isinf(b));
        vec2 clamped = clamp(ab, 0.0, 1.0);
        float miss = finite ? dot(ab - clamped, ab - clamped) : 1e29;
        if (miss < best_miss) {
            best_miss = miss;
            best = finite ? clamped : vec2(0.5);
        }
    }
    return best;
}
#endif

// The pixels of the square ``square`` (its vertex 00 in the whole lattice's points; scan
// index k) of image ``image``, its vertices' output points q (00, 10, 11, 01: the order of
// the edges and of the nearest's ties).
void paper_scan(vec2 q[4], ivec2 square, uint k, int image) {
    vec2 lo = min(min(q[0], q[1]), min(q[2], q[3]));
    vec2 hi = max(max(q[0], q[1]), max(q[2], q[3]));
    if (any(isnan(lo)) || any(isnan(hi))) {
        return;
    }
    // the bounding rectangle, widened by the tolerance of the edges
    ivec2 first = max(ivec2(ceil(lo - PAPER_TOLERANCE)), ivec2(0));
    ivec2 last = min(ivec2(floor(hi + PAPER_TOLERANCE)), u_target_size - 1);
    if (!scan_piece(first, last)) {
        return;   // a large square's piece it does not have (common/pieces.glsl)
    }
    int top = image * u_target_size.y;   // the image's first row of the atlas
    for (int y = first.y; y <= last.y; ++y) {
        for (int x = first.x; x <= last.x; ++x) {
            vec2 p = vec2(x, y);
            bool odd = false;
            bool edge = false;
            float nearest = 1e38;
            uint v = 0u;
            for (int j = 0; j < 4; ++j) {
                vec2 a = q[j];
                vec2 b = q[(j + 1) & 3];
                odd = odd != crosses(a, b, p);
                edge = edge || near_edge(a, b, p);
                vec2 d = a - p;
                float d2 = dot(d, d);
                if (d2 < nearest) {   // strictly: ties keep the earlier vertex
                    nearest = d2;
                    v = uint(j);
                }
            }
            if (!(odd || edge)) {
                continue;
            }
            uint key = ~(4u * k + v);
            int i = (top + y) * u_target_size.x + x;
#if WARP_PAPER_STAGE == 0
            // a pixel an earlier square holds keeps it: no atomic (they cost a CPU driver
            // one lane at a time), and a stale read only leaves the atomic to decide
            atomicMax(warp_winner[i], key);
#else
            if (warp_winner[i] == key) {
                vec2 ab = inverse_bilinear(q[0], q[1], q[2], q[3], p);
                vec2 s = vec2(square + u_lattice_offset) + ab;
                imageStore(u_map, ivec2(x, top + y), vec4(s, 0.0, 1.0));
            }
#endif
        }
    }
}
