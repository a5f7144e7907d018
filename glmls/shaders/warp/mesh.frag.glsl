// Fills the deformed quads / points: the colour of the source at the interpolated source
// point, or (WARP_OUTPUT_COORDS) the source point itself, which gives the backward method
// its first guess (a piecewise linear inverse of f).
#include "warp/sample.glsl"

uniform ivec2 u_mesh_dims;    // vertices per row, rows of this band
uniform int u_first_row;      // mesh row of the band's first row

in vec2 v_source;
#if WARP_SPLAT
flat in ivec2 v_pixel;
#endif

layout(location = 0) out vec4 out_color;

void main() {
#if WARP_OUTPUT_COORDS
    out_color = vec4(v_source + vec2(u_lattice_offset), 1.0, 0.0);   // source pixels
#elif WARP_SPLAT
    out_color = warp_fetch(v_source, v_pixel, v_pixel);
#else
    // The cell being drawn (two triangles each, in reverse order; see warp/mesh.vert.glsl):
    // nearest sampling stays inside it.
    int cells_x = u_mesh_dims.x - 1;
    int cell = cells_x * (u_mesh_dims.y - 1) - 1 - gl_PrimitiveID / 2;
    ivec2 first = ivec2(cell % cells_x, cell / cells_x + u_first_row) * u_grid;
    out_color = warp_fetch(v_source, first, min(first + u_grid - 1, u_lattice_size - 1));
#endif
}
