// Sets every pixel's source point of the adaptive fill (adaptive/scan.comp.glsl) to
// ADAPTIVE_NONE, "no triangle covers it" (a pattern clear of the buffer costs ~18 ms at
// 1024^2 through moderngl; this pass well under one).
layout(local_size_x = LOCAL_SIZE) in;
#ifndef ADAPTIVE_NONE
#define ADAPTIVE_NONE 3.0e38   // glmls.imaging.adaptive.scan.NONE: no source point
#endif

#include "common/groups.glsl"

layout(std430, binding = BIND_ADAPTIVE_POINTS) writeonly buffer AdaptivePoints {
    vec2 adaptive_point[];
};

uniform int u_count;
uniform int u_offset;

void main() {
    int i = u_offset + int(dispatch_item());
    if (i < u_count) {
        adaptive_point[i] = vec2(ADAPTIVE_NONE);
    }
}
