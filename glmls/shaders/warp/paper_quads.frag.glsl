// Fills each target pixel with the colour of the vertex that warp/paper_quads.comp.glsl
// chose for it (method "paper-quads", nearest): the key ~(4 k + v) holds the winning square's
// scan index k and its vertex v (00, 10, 11, 01) nearest to the pixel centre. One texel
// fetch per pixel, no mesh (the same for a lattice evaluated in bands). Drawn as one
// full-viewport triangle; the viewport has the target's size. Pixels no square covers are
// discarded (the background stays).
#include "warp/target.glsl"
#include "warp/sample.glsl"

layout(binding = BIND_WINNER_TEXTURE) uniform usampler2D u_winner;
uniform int u_squares_x;   // squares per row of the lattice (points per row - 1)

layout(location = 0) out vec4 out_color;

void main() {
    ivec2 p = warp_target_pixel();
    uint id = texelFetch(u_winner, p, 0).r;
    if (id == 0u) {
        discard;
    }
    uint key = ~id;
    uint k = key >> 2u;
    uint v = key & 3u;
    uint row = k / uint(u_squares_x);
    ivec2 square = ivec2(int(k - row * uint(u_squares_x)), int(row));
    // v: 0 = (0, 0), 1 = (1, 0), 2 = (1, 1), 3 = (0, 1)
    ivec2 corner = ivec2(v == 1u || v == 2u ? 1 : 0, v >= 2u ? 1 : 0);
    out_color = warp_texel(square + corner + u_lattice_offset);
}
