// The sources of a batch's chunk as the caller's bytes (glmls.batch.texels): its (N, H, W, C)
// uint8 images one after the other, BATCH_CHANNELS bytes a pixel, in a uint32 table
// (common/table.glsl, little-endian words) read as an r32ui image, and with BATCH_LABELS the
// (N, H, W) uint8 labels in a table of their own. warp_source_texel makes the RGBA8 texel that
// the single warp's texture holds (glmls.imaging.source.as_rgba8: missing channels 0, alpha
// 255; a label as the channel after the image's), so nothing is converted on the host.
// warp_store writes a texel into the atlas of output canvases, an RGBA8 texture bound as r32ui
// (glmls.gl.bindings.bind_texels) whose texel i, laid out as a table's item i, is pixel i of
// the canvases, row-major, u_atlas_width pixels a row (batch/pack.comp.glsl packs it).
// Images and tables, not storage buffers: a scan's lanes read and write different words,
// which llvmpipe's image loads and stores gather and scatter at once, where it loads a storage
// buffer lane by lane (the chunk's scans take about 0.6x the time); GPUs read either as fast.
#include "common/table.glsl"

layout(r32ui, binding = BIND_BATCH_SOURCE) readonly uniform uimage2D batch_source_words;
#if BATCH_LABELS
layout(r32ui, binding = BIND_BATCH_LABEL_IMAGE) readonly uniform uimage2D batch_label_words;
#endif
layout(r32ui, binding = BIND_TEXEL_TARGET) writeonly uniform uimage2D batch_atlas_image;
uniform int u_atlas_width;
// (u_source_size: W, H of one source image, declared by the including shader)

// The n (1..4) bytes from byte b of a table of words, little-endian (the first the lowest).
#define BATCH_BYTES_AT(words, b, n, out)                                              \
    {                                                                                 \
        uint word_ = (b) >> 2u;                                                       \
        uint shift_ = ((b) & 3u) * 8u;                                                \
        out = TABLE_LOAD(words, word_) >> shift_;                                     \
        if (shift_ + 8u * (n) > 32u) {                                                \
            out |= TABLE_LOAD(words, word_ + 1u) << (32u - shift_);                   \
        }                                                                             \
        out = (n) == 4u ? out : out & ((1u << (8u * (n))) - 1u);                      \
    }

// The texel of source pixel s of the sources' atlas (image k's rows k * H ...).
uint warp_source_texel(ivec2 s) {
    uint i = uint(s.y * u_source_size.x + s.x);
    uint texel;
    BATCH_BYTES_AT(batch_source_words, i * uint(BATCH_CHANNELS), uint(BATCH_CHANNELS), texel)
#if BATCH_LABELS
    uint label;
    BATCH_BYTES_AT(batch_label_words, i, 1u, label)
    texel |= label << (8u * uint(BATCH_CHANNELS));
#endif
#if BATCH_CHANNELS + BATCH_LABELS < 4
    texel |= 0xFF000000u;
#endif
    return texel;
}

// Texel ``texel`` at atlas pixel ``pixel``; (-1, -1): nothing to draw.
void warp_store(ivec2 pixel, uint texel) {
    if (pixel.x >= 0) {
        imageStore(batch_atlas_image, table_texel(pixel.y * u_atlas_width + pixel.x),
                   uvec4(texel));
    }
}
