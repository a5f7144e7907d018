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

// The image pixel that lattice pixel p shows, by the border rule past the image. With the
// constant border the lattice has no margin: p itself, and nothing more per pixel.
ivec2 lattice_source_pixel(ivec2 p, ivec2 source_size) {
#if WARP_BORDER == 0
    return p;
#else
    return border_pixel(p + u_lattice_offset, source_size);
#endif
}
