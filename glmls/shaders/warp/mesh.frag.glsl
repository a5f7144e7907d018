// Fills the deformed quads / points: the colour of the source at the interpolated source
// point, or (WARP_OUTPUT_COORDS) the source point itself, which gives the backward method
// its first guess (a piecewise linear inverse of f).
#include "warp/sample.glsl"

uniform ivec2 u_mesh_dims;    // vertices per row, rows of this band
uniform int u_first_row;      // mesh row of the band's first row

#if WARP_SPLAT
flat in ivec2 v_pixel;
#else
noperspective in vec4 v_offsets;   // see warp/mesh.vert.glsl
#endif

layout(location = 0) out vec4 out_color;

void main() {
#if WARP_SPLAT
    vec2 source = vec2(v_pixel);
    ivec2 first = v_pixel;
    ivec2 last = v_pixel;
#else
    // The cell being drawn (two triangles each, in reverse order; see warp/mesh.vert.glsl):
    // its corner 00 plus the offset in it; nearest sampling stays inside it.
    int cells_x = u_mesh_dims.x - 1;
    int cell = cells_x * (u_mesh_dims.y - 1) - 1 - gl_PrimitiveID / 2;
    ivec2 ij = ivec2(cell % cells_x, cell / cells_x + u_first_row);
    bvec2 odd = equal(ij & 1, ivec2(1));
    vec2 offset = vec2(odd.x ? v_offsets.z : v_offsets.x, odd.y ? v_offsets.w : v_offsets.y);
    vec2 source = lattice_corner(ij) + offset;
    ivec2 first = ij * u_grid;
    ivec2 last = min(first + u_grid - 1, u_lattice_size - 1);
#endif
#if WARP_OUTPUT_COORDS
    out_color = vec4(source + vec2(u_lattice_offset), 1.0, 0.0);   // source pixels
#else
    out_color = warp_fetch(source, first, last);
#endif
}
