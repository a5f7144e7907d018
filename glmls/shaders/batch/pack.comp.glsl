// The atlas of a batch's output canvases (RGBA8, read as r32ui) as the caller's bytes: four
// pixels an invocation, their first BATCH_CHANNELS bytes packed one after the other into
// BATCH_CHANNELS words (the (N, H, W, C) uint8 array, row k * H + y of the atlas being image
// k's row y), and with BATCH_LABELS the next byte of each (a label that rode as the channel
// after the image's) into one word from word u_labels_at: one read-back of the chunk into
// the caller's arrays, no channel dropped on the host.
layout(local_size_x = LOCAL_SIZE) in;

#include "common/groups.glsl"

layout(r32ui, binding = BIND_TEXEL_SOURCE) readonly uniform uimage2D batch_atlas;
layout(std430, binding = BIND_BATCH_OUTPUT) writeonly buffer BatchOutput {
    uint batch_out[];
};
uniform int u_atlas_width;
uniform uint u_pixels;     // pixels of the atlas
uniform int u_offset;      // first item of this dispatch
#if BATCH_LABELS
uniform uint u_labels_at;  // the labels' first word
#endif

void main() {
    uint j = uint(u_offset) + dispatch_item();
    if (4u * j >= u_pixels) {
        return;
    }
    uint texels[4];
    for (uint q = 0u; q < 4u; ++q) {
        uint p = 4u * j + q;
        ivec2 xy = ivec2(int(p % uint(u_atlas_width)), int(p / uint(u_atlas_width)));
        texels[q] = p < u_pixels ? imageLoad(batch_atlas, xy).x : 0u;
    }
#if BATCH_CHANNELS == 4
    for (uint q = 0u; q < 4u; ++q) {
        batch_out[4u * j + q] = texels[q];
    }
#else
    const uint bits = 8u * uint(BATCH_CHANNELS);
    uint word = uint(BATCH_CHANNELS) * j;
    uint value = 0u;
    uint filled = 0u;
    for (uint q = 0u; q < 4u; ++q) {
        uint bytes = texels[q] & ((1u << bits) - 1u);
        value |= bytes << filled;
        filled += bits;
        if (filled >= 32u) {
            batch_out[word] = value;
            ++word;
            filled -= 32u;
            value = filled > 0u ? bytes >> (bits - filled) : 0u;
        }
    }
#endif
#if BATCH_LABELS
    uint labels = 0u;
    for (uint q = 0u; q < 4u; ++q) {
        labels |= ((texels[q] >> (8u * uint(BATCH_CHANNELS))) & 0xFFu) << (8u * q);
    }
    batch_out[u_labels_at + j] = labels;
#endif
}
