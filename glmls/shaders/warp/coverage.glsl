// OpenGL's coverage rule for the compute scan conversions (warp/cells.comp.glsl for the
// regular mesh, warp/adaptive.comp.glsl for the adaptive one): pixel centres strictly inside,
// and on an edge for one of the two primitives sharing it (a top-left style tie rule).

// The edge function of edge (a, b) at p. `precise`: the two primitives on either side of an
// edge, evaluating it from the same end points in the same order, see exactly opposite
// values, so no pixel of a seam is lost or drawn twice.
float edge(vec2 a, vec2 b, vec2 p) {
    precise float e = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
    return e;
}

// Is an edge value e (already multiplied by the primitive's orientation) covering? d is the
// edge's direction along the primitive's counter-clockwise boundary.
bool covers(float e, vec2 d) {
    return e > 0.0 || (e == 0.0 && (d.y > 0.0 || (d.y == 0.0 && d.x > 0.0)));
}

// How far the row spans are widened against rounding before the exact edge tests.
#define SPAN_MARGIN 0.01

// Narrow [left, right] to where the row y is on the inner side of the edge a -> b of a
// convex primitive of orientation s (edge(a, b, p) s >= 0 inside).
void span(vec2 a, vec2 b, float s, float y, inout float left, inout float right) {
    vec2 d = b - a;
    if (d.y == 0.0) {
        // parallel to the rows: all of the row is on one side
        right = s * d.x * (y - a.y) >= 0.0 ? right : left - 1.0;
        return;
    }
    float x = a.x + d.x * (y - a.y) / d.y;   // where the edge crosses the row
    if (s * d.y > 0.0) {
        right = min(right, x);
    } else {
        left = max(left, x);
    }
}
