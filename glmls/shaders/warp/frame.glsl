// The output frame (glmls.imaging.frame.Frame): output pixel (column i, row j) shows the point
// u_origin + (i, j) of the deformed image.
#ifndef MLS_BATCH
#define MLS_BATCH 0
#endif
#if !MLS_BATCH  // a batch's passes set these per image (mls/batch.glsl)
uniform vec2 u_center;   // scaled -> pixels: pixel = scaled * u_scale + u_center
uniform float u_scale;
#endif
uniform vec2 u_origin;

// Where a deformed point (scaled) falls in the output, in output pixels.
vec2 warp_output_point(vec2 scaled) {
    return scaled * u_scale + u_center - u_origin;
}
