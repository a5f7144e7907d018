// Fills each target pixel with the colour of the vertex that warp/paper_quads.comp.glsl
// chose for it (method "paper-quads", nearest): the key names the winning square and its
// vertex nearest to the pixel centre (warp/paper_key.glsl). One texel fetch per pixel, no
// mesh (the same for a lattice evaluated in bands). Drawn as one full-viewport triangle; the
// viewport has the target's size. Pixels no square covers are discarded (the background
// stays).
#include "warp/target.glsl"
#include "warp/sample.glsl"
#include "warp/paper_key.glsl"

layout(binding = BIND_WINNER_TEXTURE) uniform usampler2D u_winner;

layout(location = 0) out vec4 out_color;

void main() {
    ivec2 p = warp_target_pixel();
    uint id = texelFetch(u_winner, p, 0).r;
    if (id == 0u) {
        discard;
    }
    out_color = warp_texel(paper_key_point(id) + u_lattice_offset);
}
