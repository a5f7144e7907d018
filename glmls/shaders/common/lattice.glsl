// The corner lattice of glmls.core.mesh.MeshLattice in pixel coordinates: the corners of the
// pixel squares every u_grid pixels, the last one on the image border (pixel centres sit at
// integers, so corners at half-integers).
uniform int u_grid;   // mesh step in pixels

// Corner k along an axis of n pixels.
float lattice_corner(int k, int n) {
    return min(float(k * u_grid), float(n)) - 0.5;
}

// Corner (i, j) of an image of ``size`` = (W, H) pixels.
vec2 lattice_corner(ivec2 ij, ivec2 size) {
    return min(vec2(ij * u_grid), vec2(size)) - 0.5;
}
