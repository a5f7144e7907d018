// Fills each target pixel with the source pixel that warp/cells.comp.glsl (WARP_CELLS_SOURCE)
// chose for it: nearest sampling, so the scan conversion already knows the pixel and stores
// it in the winning key (cell row, cell column, triangle, pixel in the cell). One texel
// fetch per pixel, no mesh: this pass is the same for a mesh evaluated in bands. Drawn as one
// full-viewport triangle; the viewport has the target's size. Pixels no triangle covers are
// discarded (the background stays).
#include "warp/target.glsl"
#include "warp/cells_key.glsl"
#include "warp/sample.glsl"

layout(binding = BIND_WINNER_TEXTURE) uniform usampler2D u_winner;

layout(location = 0) out vec4 out_color;

void main() {
    ivec2 p = warp_target_pixel();
    uint id = texelFetch(u_winner, p, 0).r;
    if (id == 0u) {
        discard;
    }
    out_color = warp_texel(warp_key_source_pixel(id) + u_lattice_offset);
}
