// Fills the atlas of a batch's output canvases (image k's rows k * H .. k * H + H - 1) from
// the keys of batch/paper_quads.comp.glsl, as a single image's paper-quads fill does
// (warp/paper_quads.frag.glsl, nearest: the vertex's source pixel; warp/backward.frag.glsl,
// linear: the source point that the scan's stage 1 wrote into u_coords, sampled bilinearly);
// the sources are the layers of one texture array, read past the image by the border rule
// WARP_BORDER (the lattice then has a margin, u_lattice_offset). Pixels without a key are
// discarded (the background stays).
// BATCH_PAPER_LABELS: the chunk's label images at the key's source pixel (nearest) into the
// next attachment. BATCH_PAPER_DRAWN: the number of the image pixel drawn plus one,
// (x + 1, y + 1, 0, 0), into the last, as a nearest warp of an image of those numbers writes
// them.
#include "common/lattice.glsl"
#include "warp/paper_key.glsl"

#ifndef BATCH_PAPER_LABELS
#define BATCH_PAPER_LABELS 0
#endif
#ifndef BATCH_PAPER_DRAWN
#define BATCH_PAPER_DRAWN 0
#endif

layout(binding = BIND_SOURCE) uniform sampler2DArray u_sources;
layout(binding = BIND_WINNER_TEXTURE) uniform usampler2D u_winner;   // the atlas's keys
#if WARP_LINEAR
layout(binding = BIND_COORDS) uniform sampler2D u_coords;   // (s.x, s.y, 0, covered)
#endif

uniform ivec2 u_target_size;  // W, H of one image's output canvas
uniform ivec2 u_source_size;  // W, H of the source images

#include "batch/sample.glsl"

layout(location = 0) out vec4 out_color;
#if BATCH_PAPER_LABELS
layout(binding = BIND_LABEL_SOURCES) uniform sampler2DArray u_label_sources;
layout(location = 1) out vec4 out_label;
#endif
#if BATCH_PAPER_DRAWN && BATCH_PAPER_LABELS
layout(location = 2) out vec4 out_drawn;
#elif BATCH_PAPER_DRAWN
layout(location = 1) out vec4 out_drawn;
#endif

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
#if BATCH_PAPER_LABELS || BATCH_PAPER_DRAWN
    ivec2 shown = border_pixel(p, u_source_size);
#endif
#if BATCH_PAPER_LABELS
    out_label = texelFetch(u_label_sources, ivec3(shown, k), 0);
#endif
#if BATCH_PAPER_DRAWN
    out_drawn = vec4(vec2(shown + 1), 0.0, 0.0);
#endif
}
