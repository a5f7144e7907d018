// The paper's "forward with polygon interpolation" as its pseudo-code says (method
// "paper-quads"; the float64 reference is glmls.core.paper_quads, whose rules this follows):
// squares S of four adjacent pixel centres, Q = f at its vertices, the pixel centres P in Q's
// bounding rectangle that are inside Q (crossing number of a ray towards +x, or within
// PAPER_TOLERANCE of an edge) and not yet marked get the colour of S's vertex whose deformed
// position is nearest to P.
//
// "Not yet marked", with the squares in row-major scan order, is "the first square in scan
// order that contains P": one invocation per square, in any order, records per pixel the key
// ~(4 k + v) with atomicMax (k the square's scan index, v its vertex nearest to P in the order
// 00, 10, 11, 01), so the smallest k wins whatever order the invocations run in, and the
// winner carries its vertex. 0 = not covered (the buffer is cleared to 0).
//
//   WARP_PAPER_STAGE 0: mark (the keys).
//                    1: (linear) each square writes, at the pixels it won, the source point
//                       of P by inverting Q's bilinear map: (x + a, y + b) with
//                       Q(a, b) = P, into u_map as (s.x, s.y, 0, covered) for
//                       warp/backward.frag.glsl.
//
// The squares are those of a glmls.core.mesh.MeshLattice of pixel centres (possibly with a
// margin past the image for the border modes), evaluated in bands that share a row
// (glmls.imaging.bands): each band's squares are its rows' squares, k is the whole lattice's.
layout(local_size_x = LOCAL_SIZE) in;

#include "common/groups.glsl"
#include "warp/frame.glsl"
// a large square is walked in pieces on llvmpipe; a pixel runs the loops over the square's
// vertices (4) and the roots (2) besides its own step
#define SCAN_PIECE_COST 8
#include "common/pieces.glsl"

layout(std430, binding = BIND_DEFORMED) readonly buffer WarpMesh {
    vec2 warp_mesh[];   // f at the band's pixel centres, scaled coordinates
};
layout(std430, binding = BIND_WINNER) buffer WarpWinner {
    uint warp_winner[];   // per target pixel, row-major: ~(4 k + v) of the winner, 0 = none
};
#if WARP_PAPER_STAGE == 1
layout(rgba32f, binding = BIND_INVERSE_MAP) writeonly uniform image2D u_map;
#endif

uniform ivec2 u_target_size;  // W, H in pixels
uniform ivec2 u_mesh_dims;    // points per row, rows (of this band)
uniform int u_first_row;      // lattice row of the band's first row
uniform int u_offset;         // first square of this dispatch
uniform ivec2 u_lattice_offset;   // the source pixel of lattice point (0, 0)

vec2 vertex_px(int i) {
    return warp_output_point(warp_mesh[i]);
}

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

void main() {
    int squares_x = u_mesh_dims.x - 1;
    int square = u_offset + int(dispatch_item());
    if (square >= squares_x * (u_mesh_dims.y - 1)) {
        return;
    }
    int sy = square / squares_x;
    int sx = square - sy * squares_x;
    int i00 = sy * u_mesh_dims.x + sx;   // in the band
    vec2 q[4];   // 00, 10, 11, 01: the order of the edges and of the nearest's ties
    q[0] = vertex_px(i00);
    q[1] = vertex_px(i00 + 1);
    q[2] = vertex_px(i00 + u_mesh_dims.x + 1);
    q[3] = vertex_px(i00 + u_mesh_dims.x);
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
    int row = sy + u_first_row;
    uint k = uint(row) * uint(squares_x) + uint(sx);   // scan index in the whole lattice
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
            int i = y * u_target_size.x + x;
#if WARP_PAPER_STAGE == 0
            atomicMax(warp_winner[i], key);
#else
            if (warp_winner[i] == key) {
                vec2 ab = inverse_bilinear(q[0], q[1], q[2], q[3], p);
                vec2 s = vec2(ivec2(sx, row) + u_lattice_offset) + ab;
                imageStore(u_map, ivec2(x, y), vec4(s, 0.0, 1.0));
            }
#endif
        }
    }
}
