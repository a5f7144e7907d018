// Fills the atlas of a batch's output canvases (image k's rows k * H .. k * H + H - 1) from
// the winner keys of batch/cells.comp.glsl (pixels without a key, the background or, with
// BATCH_CELLS_LINEAR, those the scan coloured itself, are left as they are), as warp/cells_nearest.frag.glsl (nearest: the
// key's source pixel) and warp/cells.frag.glsl (linear: the winning triangle interpolated at
// the pixel centre, then sampled bilinearly) fill a single image's canvas; the sources are
// the layers of one texture array, read past the image by the border rule WARP_BORDER (the
// lattice then has a margin, u_lattice_offset).
// WARP_OUTPUT_COORDS (with WARP_LINEAR): the interpolated source point instead of a colour,
// (s.x, s.y, 1, 0), as warp/cells.frag.glsl writes it.
// BATCH_RESOLVE_LABELS (keys that carry the nearest source pixel): the chunk's label images
// too, layers of a second texture array read at that pixel into a second attachment, as a
// nearest resolve of them alone would write them, in the same draw.
#include "common/lattice.glsl"
#include "batch/mesh.glsl"

#ifndef WARP_OUTPUT_COORDS
#define WARP_OUTPUT_COORDS 0
#endif
#ifndef BATCH_RESOLVE_LABELS
#define BATCH_RESOLVE_LABELS 0
#endif

layout(binding = BIND_SOURCE) uniform sampler2DArray u_sources;
layout(binding = BIND_WINNER_TEXTURE) uniform usampler2D u_winner;   // the atlas's keys

uniform ivec2 u_target_size;  // W, H of one image's output canvas
uniform ivec2 u_source_size;  // W, H of the source images
uniform int u_sub_bits;       // key layout, see warp/cells.comp.glsl
uniform int u_col_shift;
uniform int u_row_shift;

#include "batch/sample.glsl"

layout(location = 0) out vec4 out_color;
#if BATCH_RESOLVE_LABELS
layout(binding = BIND_LABEL_SOURCES) uniform sampler2DArray u_label_sources;
layout(location = 1) out vec4 out_label;
#endif

// The source pixel a key carries (keys made with the nearest source pixel), before the
// lattice's offset.
ivec2 key_source_pixel(uint key) {
    uint sub_mask = (1u << u_sub_bits) - 1u;
    ivec2 sub = ivec2(key & sub_mask, (key >> u_sub_bits) & sub_mask);
    uint columns = key & ((1u << u_row_shift) - 1u);
    return ivec2(columns >> u_col_shift, key >> u_row_shift) * u_grid + sub;
}

void main() {
    ivec2 atlas = ivec2(gl_FragCoord.xy);
    uint id = texelFetch(u_winner, atlas, 0).r;
    if (id == 0u) {
        discard;
    }
    int k = atlas.y / u_target_size.y;
    ivec2 p = ivec2(atlas.x, atlas.y - k * u_target_size.y);
    uint key = 0x80000000u - id;
#if BATCH_RESOLVE_LABELS
    ivec2 nearest = border_pixel(key_source_pixel(key) + u_lattice_offset, u_source_size);
    out_label = texelFetch(u_label_sources, ivec3(nearest, k), 0);
#endif
#if WARP_LINEAR
    // the triangle's bit sits above the source pixel's (keys made for nearest labels too)
    int triangle = int((key >> uint(2 * u_sub_bits)) & 1u);
    uint columns = key & ((1u << u_row_shift) - 1u);
    ivec2 g = ivec2(columns >> u_col_shift, int(key >> u_row_shift));
    ivec2 kb = triangle == 0 ? ivec2(1, 0) : ivec2(1, 1);
    ivec2 kc = triangle == 0 ? ivec2(1, 1) : ivec2(0, 1);
    vec2 a = batch_vertex_px(k, g);
    vec2 b = batch_vertex_px(k, g + kb);
    vec2 d = batch_vertex_px(k, g + kc);
    vec2 s = lattice_source_point(a, b, d, g, kb, kc, vec2(p)) + vec2(u_lattice_offset);
#if WARP_OUTPUT_COORDS
    out_color = vec4(s, 1.0, 0.0);   // the source point itself (the map of the output pixels)
#else
    out_color = batch_sample(s, k);
#endif
#else
    ivec2 s = key_source_pixel(key);
    out_color = texelFetch(u_sources, ivec3(border_pixel(s + u_lattice_offset, u_source_size), k), 0);
#endif
}
