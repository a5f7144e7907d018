// Draws the deformed mesh (quads) or the deformed pixel centres (splat). There are no vertex
// attributes: gl_VertexID is the vertex's index in the band (quads: through the cached index
// buffer, two triangles (00, 11, 01) and (00, 10, 11) per cell, cells in reverse row-major
// source order; splat: points in reverse order), and the deformed positions come from the
// buffer that mls/points.comp.glsl (MLS_LATTICE) filled, so nothing goes back to the CPU in
// between. Reverse order because later primitives are drawn over earlier ones: where the
// map folds, the first source cell (pixel) in scan order shows (glmls.imaging.raster).
//
//   WARP_SPLAT  0: quads; 1: one point per source pixel (the paper's simple forward).
//
// Coordinates: pixel centres at integers, (x, y) = (column, row). u_target_size pixels map
// onto the viewport; image row 0 lands on the framebuffer's first row, which is what
// glReadPixels returns first, so images come back top-down without a flip. A window, whose
// row 0 is at the bottom of the screen, sets u_flip_y.

#include "common/lattice.glsl"
#include "warp/frame.glsl"

layout(std430, binding = BIND_DEFORMED) readonly buffer WarpMesh {
    vec2 warp_mesh[];   // f at the band's vertices, scaled coordinates
};

uniform ivec2 u_target_size;  // W, H of the output, in pixels
uniform bool u_flip_y;
uniform ivec2 u_mesh_dims;    // vertices per row, rows of this band
uniform int u_first_row;      // mesh row (splat: pixel row) of the band's first row

#if WARP_SPLAT
flat out ivec2 v_pixel;       // the source pixel
#else
// The source point, as warp/mesh.frag.glsl puts it together: its cell's corner 00 (known
// from gl_PrimitiveID, exact) plus the offset in the cell, interpolated from these values of
// at most u_grid pixels. Interpolating the vertices' absolute source positions instead rounds
// at their magnitude (an ulp is 0.002 px at 16384 px), which leaves a bilinear weight on the
// neighbouring texel where the identity should give the input exactly. A vertex's value is a
// function of the vertex alone, shared by the cells around it: along each axis its distance
// from the previous vertex where its index is odd and 0 where even (x, y: the offset in cells
// of even index), and the other way round (z, w: in cells of odd index).
noperspective out vec4 v_offsets;

// Vertex k's values along an axis of n pixels: (for the even cells, for the odd cells).
vec2 offsets(int k, int n) {
    float d = k > 0 ? lattice_corner(k, n) - lattice_corner(k - 1, n) : 0.0;
    return (k & 1) == 1 ? vec2(d, 0.0) : vec2(0.0, d);
}
#endif

void main() {
#if WARP_SPLAT
    int i = u_mesh_dims.x * u_mesh_dims.y - 1 - gl_VertexID;
#else
    int i = gl_VertexID;
#endif
    ivec2 ij = ivec2(i % u_mesh_dims.x, i / u_mesh_dims.x + u_first_row);
#if WARP_SPLAT
    v_pixel = ij;
#else
    vec2 x = offsets(ij.x, u_lattice_size.x);
    vec2 y = offsets(ij.y, u_lattice_size.y);
    v_offsets = vec4(x.x, y.x, x.y, y.y);
#endif
    vec2 pixel = warp_output_point(warp_mesh[i]);
#if WARP_SPLAT
    // round(f(v)) here, a pixel centre: the rasteriser's sub-pixel snapping (1/256 px) would
    // round points within that of a half-integer the other way
    pixel = floor(pixel + 0.5);
#endif
    vec2 ndc = (pixel + 0.5) / vec2(u_target_size) * 2.0 - 1.0;
    gl_Position = vec4(ndc.x, u_flip_y ? -ndc.y : ndc.y, 0.0, 1.0);
}
