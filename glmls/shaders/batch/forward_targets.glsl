// The attachments of a batch's forward draw (glmls.batch.canvases.ForwardTargets), in order:
// the images' colours (out_color); with BATCH_FORWARD_LABELS the chunk's label images at the
// source pixel drawn (nearest); with BATCH_FORWARD_DRAWN the number of the image pixel drawn
// plus one, (x + 1, y + 1, 0, 0), as a nearest warp of an image of those numbers writes them.
// Include after batch/sample.glsl (border_pixel, u_source_size).
#ifndef BATCH_FORWARD_LABELS
#define BATCH_FORWARD_LABELS 0
#endif
#ifndef BATCH_FORWARD_DRAWN
#define BATCH_FORWARD_DRAWN 0
#endif

layout(location = 0) out vec4 out_color;
#if BATCH_FORWARD_LABELS
layout(binding = BIND_LABEL_SOURCES) uniform sampler2DArray u_label_sources;
layout(location = 1) out vec4 out_label;
#endif
#if BATCH_FORWARD_DRAWN && BATCH_FORWARD_LABELS
layout(location = 2) out vec4 out_drawn;
#elif BATCH_FORWARD_DRAWN
layout(location = 1) out vec4 out_drawn;
#endif

// The label and the number of source pixel p of image k (past the image: the border rule's
// pixel), into their attachments.
void forward_store_labels(ivec2 p, int k) {
#if BATCH_FORWARD_LABELS || BATCH_FORWARD_DRAWN
    ivec2 shown = border_pixel(p, u_source_size);
#endif
#if BATCH_FORWARD_LABELS
    out_label = texelFetch(u_label_sources, ivec3(shown, k), 0);
#endif
#if BATCH_FORWARD_DRAWN
    out_drawn = vec4(vec2(shown + 1), 0.0, 0.0);
#endif
}
