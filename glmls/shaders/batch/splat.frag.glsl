// Colours a batch's splatted points (batch/splat.vert.glsl) from layer v_image of the
// sources, as warp/mesh.frag.glsl (WARP_SPLAT) colours one image's: the source pixel itself
// (nearest), or the bilinear sample at its centre (which is that pixel's value), read past
// the image by the border rule WARP_BORDER (the lattice then has a margin, u_lattice_offset).
// BATCH_SPLAT_LABELS: the chunk's label images at the same pixel (nearest) into the next
// attachment. BATCH_SPLAT_DRAWN: the number of the image pixel drawn plus one, (x + 1, y + 1,
// 0, 0), into the last, as a nearest warp of an image of those numbers writes them.
#include "common/lattice.glsl"

#ifndef BATCH_SPLAT_LABELS
#define BATCH_SPLAT_LABELS 0
#endif
#ifndef BATCH_SPLAT_DRAWN
#define BATCH_SPLAT_DRAWN 0
#endif

layout(binding = BIND_SOURCE) uniform sampler2DArray u_sources;
uniform ivec2 u_source_size;  // W, H of the source images

#include "batch/sample.glsl"

flat in ivec2 v_pixel;
flat in int v_image;

layout(location = 0) out vec4 out_color;
#if BATCH_SPLAT_LABELS
layout(binding = BIND_LABEL_SOURCES) uniform sampler2DArray u_label_sources;
layout(location = 1) out vec4 out_label;
#endif
#if BATCH_SPLAT_DRAWN && BATCH_SPLAT_LABELS
layout(location = 2) out vec4 out_drawn;
#elif BATCH_SPLAT_DRAWN
layout(location = 1) out vec4 out_drawn;
#endif

void main() {
    ivec2 p = v_pixel + u_lattice_offset;
#if WARP_LINEAR
    out_color = batch_sample(vec2(v_pixel) + vec2(u_lattice_offset), v_image);
#else
    out_color = batch_texel(p, v_image);
#endif
#if BATCH_SPLAT_LABELS || BATCH_SPLAT_DRAWN
    ivec2 shown = border_pixel(p, u_source_size);
#endif
#if BATCH_SPLAT_LABELS
    out_label = texelFetch(u_label_sources, ivec3(shown, v_image), 0);
#endif
#if BATCH_SPLAT_DRAWN
    out_drawn = vec4(vec2(shown + 1), 0.0, 0.0);
#endif
}
