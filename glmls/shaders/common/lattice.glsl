// The corner lattice of glmls.core.mesh.MeshLattice in pixel coordinates: the corners of the
// pixel squares every u_grid pixels, the last one on the lattice's border (pixel centres sit
// at integers, so corners at half-integers). Coordinates here are the lattice's own: its
// pixel (0, 0) is source pixel u_lattice_offset (negative where the lattice extends past the
// image, for the border modes).
#include "common/border.glsl"

uniform int u_grid;                // mesh step in pixels
uniform ivec2 u_lattice_size;      // W, H of the lattice's pixel domain
uniform ivec2 u_lattice_offset;    // the source pixel of lattice pixel (0, 0)

// Corner k along an axis of n pixels.
float lattice_corner(int k, int n) {
    return min(float(k * u_grid), float(n)) - 0.5;
}

// Corner (i, j) of the lattice.
vec2 lattice_corner(ivec2 ij) {
    return min(vec2(ij * u_grid), vec2(u_lattice_size)) - 0.5;
}

// The source point (lattice pixels) at output pixel x of the triangle (a, b, d) of cell g,
// whose corners are the mesh vertices g, g + kb, g + kc (their output points a, b, d): the
// corner 00 (exact) plus the offset in the cell, whose size is a few pixels, so that its
// rounding is too (~1e-7 px). Weighting the corners' absolute positions by the barycentrics
// instead rounds at their magnitude (0.001 px at 16384 px), enough to leave a bilinear
// weight on the neighbouring texel where the identity should give the input exactly. One
// division, last: exact where the map is. The single warp's fill (warp/cells.frag.glsl) and
// a batch's (batch/resolve.frag.glsl, and the scan of its bilinear embeddings,
// batch/cells.comp.glsl) share it, so that all give the same floats.
vec2 lattice_source_point(vec2 a, vec2 b, vec2 d, ivec2 g, ivec2 kb, ivec2 kc, vec2 x) {
    float area = (b.x - a.x) * (d.y - a.y) - (b.y - a.y) * (d.x - a.x);
    float nb = (x.x - a.x) * (d.y - a.y) - (x.y - a.y) * (d.x - a.x);   // lb * area
    float nd = (b.x - a.x) * (x.y - a.y) - (b.y - a.y) * (x.x - a.x);   // ld * area
    vec2 s00 = lattice_corner(g);
    vec2 sb = lattice_corner(g + kb) - s00;
    vec2 sd = lattice_corner(g + kc) - s00;
    return s00 + (sb * nb + sd * nd) / area;
}

// The image pixel that lattice pixel p shows, by the border rule past the image. With the
// constant border the lattice has no margin: p itself, and nothing more per pixel.
ivec2 lattice_source_pixel(ivec2 p, ivec2 source_size) {
#if WARP_BORDER == 0
    return p;
#else
    return border_pixel(p + u_lattice_offset, source_size);
#endif
}
