// Fills each target pixel from the triangle that warp/cells.comp.glsl found shown there
// (the first in scan order):
// the source point is that triangle's linear interpolation of its vertices' source points at
// the pixel centre (what the rasterizer interpolates for warp/mesh.frag.glsl), then sampled
// as there (nearest: clamped to the cell). Drawn as one full-viewport triangle; the viewport
// has the target's size. Pixels no triangle covers are discarded (the background stays).
// A mesh evaluated in bands is resolved band by band: each draw fills the pixels whose
// triangle lies in its band (cell rows u_first_row .. u_first_row + rows - 2).
//
//   WARP_OUTPUT_COORDS 1: write (s.x, s.y, 1, 0) instead of the colour (backward's guess).
// Nearest colours take the shorter way of warp/cells_nearest.frag.glsl.
// A copy of the winner buffer (R32UI, one texel per pixel) as a texture: texel fetches are
// vectorised on llvmpipe, storage buffer reads go lane by lane (2x slower here); the mesh as
// warp/mesh_fetch.glsl reads it.
#include "warp/target.glsl"
#include "warp/sample.glsl"
#include "warp/frame.glsl"

layout(binding = BIND_WINNER_TEXTURE) uniform usampler2D u_winner;

uniform ivec2 u_mesh_dims;    // vertices per row, rows of this band
uniform int u_first_row;      // mesh row of the band's first row
uniform int u_col_shift;      // key layout, see warp/cells.comp.glsl (no source pixel bits)
uniform int u_row_shift;

#include "warp/mesh_fetch.glsl"

layout(location = 0) out vec4 out_color;

void main() {
    ivec2 p = warp_target_pixel();
    uint id = texelFetch(u_winner, p, 0).r;
    if (id == 0u) {
        discard;
    }
    uint key = 0x80000000u - id;   // cell row, cell column, triangle
    int triangle = int(key & 1u);
    uint columns = key & ((1u << u_row_shift) - 1u);
    ivec2 c = ivec2(columns >> u_col_shift, int(key >> u_row_shift) - u_first_row);   // in the band
    if (c.y < 0 || c.y >= u_mesh_dims.y - 1) {
        discard;   // another band's triangle
    }
    ivec2 g = c + ivec2(0, u_first_row);   // mesh row and column
    // the triangle's corners as mesh offsets: (00, 10, 11) or (00, 11, 01)
    ivec2 kb = triangle == 0 ? ivec2(1, 0) : ivec2(1, 1);
    ivec2 kc = triangle == 0 ? ivec2(1, 1) : ivec2(0, 1);
    vec2 a = warp_output_point(warp_mesh_at(c));
    vec2 b = warp_output_point(warp_mesh_at(c + kb));
    vec2 d = warp_output_point(warp_mesh_at(c + kc));
    // the source point at the pixel centre, in the triangle
    vec2 s = lattice_source_point(a, b, d, g, kb, kc, vec2(p));
#if WARP_OUTPUT_COORDS
    out_color = vec4(s + vec2(u_lattice_offset), 1.0, 0.0);   // source pixels
#else
    ivec2 first = g * u_grid;
    out_color = warp_fetch(s, first, min(first + u_grid - 1, u_lattice_size - 1));
#endif
}
