// Fills the atlas of a batch's output canvases (image k's rows k * H .. k * H + H - 1) from
// the keys of batch/paper_quads.comp.glsl, as a single image's paper-quads fill does
// (warp/paper_quads.frag.glsl, nearest: the vertex's source pixel; warp/backward.frag.glsl,
// linear: the source point that the scan's stage 1 wrote into u_coords, sampled bilinearly);
// the sources are the layers of one texture array, read past the image by the border rule
// WARP_BORDER (the lattice then has a margin, u_lattice_offset). Pixels without a key are
// discarded (the background stays).
// The label images at the key's source pixel and the numbers of the pixels drawn:
// batch/forward_targets.glsl.
#include "common/lattice.glsl"
#include "warp/paper_key.glsl"

layout(binding = BIND_SOURCE) uniform sampler2DArray u_sources;
layout(binding = BIND_WINNER_TEXTURE) uniform usampler2D u_winner;   // the atlas's keys
#if WARP_LINEAR
layout(binding = BIND_COORDS) uniform sampler2D u_coords;   // (s.x, s.y, 0, covered)
#endif

uniform ivec2 u_target_size;  // W, H of one image's output canvas
uniform ivec2 u_source_size;  // W, H of the source images

#include "batch/sample.glsl"

#include "batch/forward_targets.glsl"

void main() {
    ivec2 atlas = ivec2(gl_FragCoord.xy);
    uint id = texelFetch(u_winner, atlas, 0).r;
    if (id == 0u) {
        discard;
    }
    int k = atlas.y / u_target_size.y;
    ivec2 p = paper_key_point(id) + u_lattice_offset;
#if WARP_LINEAR
    out_color = batch_sample(texelFetch(u_coords, atlas, 0).xy, k);
#else
    out_color = batch_texel(p, k);
#endif
    forward_store_labels(p, k);
}
