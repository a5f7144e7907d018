// OpenGL's coverage rule for the compute scan conversions (warp/cells.comp.glsl for the
// regular mesh, adaptive/scan.comp.glsl for the adaptive one): pixel centres strictly inside,
// and on an edge for one of the two primitives sharing it (a top-left style tie rule).

// The edge function of edge (a, b) at p. `precise`: the two primitives on either side of an
// edge, evaluating it from the same end points in the same order, see exactly opposite
// values, so no pixel of a seam is lost or drawn twice.
float edge(vec2 a, vec2 b, vec2 p) {
    precise float e = (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
    return e;
}

// Whether the corners ab = (a, b) and cd = (c, d) of a primitive (a triangle repeats a
// corner) are finite and within 1e9 px: one that is not covers nothing, as the conversions
// to pixel indices could not represent it (false for NaN too).
bool within_pixels(vec4 ab, vec4 cd) {
    return all(lessThan(abs(ab), vec4(1.0e9))) && all(lessThan(abs(cd), vec4(1.0e9)));
}

// The tie rule: is a pixel centre exactly on an edge covered by the primitive whose
// counter-clockwise boundary runs along the edge in direction d?
bool edge_tie(vec2 d) {
    return d.y > 0.0 || (d.y == 0.0 && d.x > 0.0);
}

// Is an edge value e (already multiplied by the primitive's orientation) covering, the tie
// rule (edge_tie) worked out beforehand where it is the same for many pixels?
bool covers_by(float e, bool tie) {
    return e > 0.0 || (e == 0.0 && tie);
}

// The same, d the edge's direction along the primitive's counter-clockwise boundary.
bool covers(float e, vec2 d) {
    return covers_by(e, edge_tie(d));
}

// How far the row spans are widened against rounding before the exact edge tests.
#define SPAN_MARGIN 0.01

// The rows of a convex polygon of orientation s (edge(a, b, p) s >= 0 inside) as bounds of
// each row's span: per edge, a point, its change in x per row, and whether it bounds the
// spans on the right (1) or the left (-1); an edge parallel to the rows (0) bounds neither:
// a convex polygon's horizontal edge is its top or bottom, and the walk's rows stop there
// (the box's, and the edge tests decide each pixel). The divisions are done once per
// polygon, not once per row.
#ifndef ROW_EDGES
#define ROW_EDGES 4   // quads; 3: triangles (the shader defines it before including this)
#endif
#if ROW_EDGES == 3
#define RowVec vec3
#else
#define RowVec vec4
#endif
struct RowBounds {
    RowVec x;       // the edges' start points
    RowVec y;
    RowVec step;
    RowVec side;
};

void row_edge(vec2 a, vec2 b, float s, out float x, out float y, out float step,
              out float side) {
    vec2 d = b - a;
    bool parallel = d.y == 0.0;
    x = a.x;
    y = a.y;
    step = parallel ? 0.0 : d.x / d.y;
    side = parallel ? 0.0 : (s * d.y > 0.0 ? 1.0 : -1.0);
}

// The bounds of the polygon (a, b, c, d), its edges ab, bc, cd, da; with ROW_EDGES 3 the
// triangle (a, b, c), its edges ab, bc, ca (d unused). Not convex: no bounds, every row whole.
RowBounds row_bounds(vec2 a, vec2 b, vec2 c, vec2 d, float s, bool convex) {
    RowBounds r;
    row_edge(a, b, s, r.x.x, r.y.x, r.step.x, r.side.x);
    row_edge(b, c, s, r.x.y, r.y.y, r.step.y, r.side.y);
#if ROW_EDGES == 3
    row_edge(c, a, s, r.x.z, r.y.z, r.step.z, r.side.z);
#else
    row_edge(c, d, s, r.x.z, r.y.z, r.step.z, r.side.z);
    row_edge(d, a, s, r.x.w, r.y.w, r.step.w, r.side.w);
#endif
    r.step = convex ? r.step : RowVec(0.0);
    r.side = convex ? r.side : RowVec(0.0);
    return r;
}

// The pixels of row y that the polygon may cover, within the columns first to last:
// (first, last) of its span, widened by SPAN_MARGIN against rounding (empty: x > y). The
// scans test each pixel's edges: the span only saves the steps outside it.
ivec2 row_span(RowBounds r, int y, int first, int last) {
    RowVec dy = RowVec(float(y)) - r.y;
    RowVec x = r.x + r.step * dy;   // where the edges cross the row
    RowVec right = mix(RowVec(3.0e38), x, greaterThan(r.side, RowVec(0.0)));
    RowVec left = mix(RowVec(-3.0e38), x, lessThan(r.side, RowVec(0.0)));
#if ROW_EDGES == 3
    float hi = min(float(last), min(min(right.x, right.y), right.z));
    float lo = max(float(first), max(max(left.x, left.y), left.z));
#else
    float hi = min(float(last), min(min(right.x, right.y), min(right.z, right.w)));
    float lo = max(float(first), max(max(left.x, left.y), max(left.z, left.w)));
#endif
    return ivec2(max(first, int(ceil(lo - SPAN_MARGIN))), min(last, int(floor(hi + SPAN_MARGIN))));
}

// A walk over a primitive's pixels, one per step, row after row, within the box first..last:
// the scans' loop. The lanes of a SIMD group run neighbouring primitives and a loop runs as
// often as its busiest lane: a loop over the rows with one over each row waits at every row
// for the group's widest span (the adaptive mesh's fans, triangles of every shape: half the
// iterations drew a pixel on W1 at 0.05 px), this one for the primitive with the most
// pixels (0.8 of them draw one). A step on an empty row (its span ends before it starts)
// draws nothing: in_row is false there, and x a column of the box.
struct RowWalk {
    int x;          // the step's pixel
    int y;
    bool in_row;    // inside the row's span
    ivec2 row;      // the span of row y
    int next;       // the column after x
};

RowWalk row_walk(RowBounds bounds, ivec2 first, ivec2 last) {
    RowWalk w;
    w.y = first.y;
    w.row = row_span(bounds, first.y, first.x, last.x);
    w.next = w.row.x;
    w.x = first.x;
    w.in_row = false;
    return w;
}

// The next step; false past the last row.
bool row_walk_next(inout RowWalk w, RowBounds bounds, ivec2 first, ivec2 last) {
    if (w.next > w.row.y) {
        ++w.y;
        w.row = row_span(bounds, w.y, first.x, last.x);
        w.next = w.row.x;
    }
    w.in_row = w.next <= w.row.y;
    w.x = min(w.next, last.x);
    ++w.next;
    return w.y <= last.y;
}
