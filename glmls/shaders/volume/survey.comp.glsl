// The box of f over each z layer of points of the band held in the lattice buffer, in
// pieces of at most VOLUME_SURVEY_PIECE points: one work group per piece of a layer (item
// u_offset + the group's number is piece item % u_pieces of layer item / u_pieces, from the
// band's first layer), its invocations striding over the piece's points (a bounded loop: a
// driver that caps loops, llvmpipe, ends longer ones early), then a reduction in shared
// memory. Out: per item (low x, y, z, high x, y, z), NaN left out (no number: +inf, -inf);
// the host reduces a layer's pieces. The construction reads these few floats back instead
// of the lattice.
#ifndef VOLUME_SURVEY_PIECE
#define VOLUME_SURVEY_PIECE (LOCAL_SIZE * 16384)
#endif
layout(local_size_x = LOCAL_SIZE) in;

#include "volume/lattice.glsl"

layout(std430, binding = BIND_VOLUME_SURVEY) writeonly buffer VolumeSurvey {
    float volume_survey[];
};

uniform int u_offset;   // the first item of this dispatch (from the band's first layer's)
uniform int u_count;    // items: layers times u_pieces
uniform int u_pieces;   // pieces a layer
uniform int u_skip_layers;   // layers of points held before the band's first

shared vec3 survey_low[LOCAL_SIZE];
shared vec3 survey_high[LOCAL_SIZE];

void main() {
    int item = u_offset + int(gl_WorkGroupID.x);
    int layer = item / u_pieces;
    int piece = item - layer * u_pieces;
    int lane = int(gl_LocalInvocationID.x);
    int points = u_lattice_dims.x * u_lattice_dims.y;
    vec3 low = vec3(uintBitsToFloat(0x7F800000u));   // +inf
    vec3 high = -low;
    if (item < u_count) {
        int first = 3 * (layer + u_skip_layers) * points;
        int end = min(points, (piece + 1) * VOLUME_SURVEY_PIECE);
        for (int k = piece * VOLUME_SURVEY_PIECE + lane; k < end; k += LOCAL_SIZE) {
            vec3 f = vec3(volume_lattice_f[first + 3 * k], volume_lattice_f[first + 3 * k + 1],
                          volume_lattice_f[first + 3 * k + 2]);
            bvec3 number = not(isnan(f));
            low = mix(low, min(low, f), number);
            high = mix(high, max(high, f), number);
        }
    }
    survey_low[lane] = low;
    survey_high[lane] = high;
    barrier();
    for (int half_ = LOCAL_SIZE / 2; half_ > 0; half_ /= 2) {
        if (lane < half_) {
            survey_low[lane] = min(survey_low[lane], survey_low[lane + half_]);
            survey_high[lane] = max(survey_high[lane], survey_high[lane + half_]);
        }
        barrier();
    }
    if (lane == 0 && item < u_count) {
        vec3 l = survey_low[0];
        vec3 h = survey_high[0];
        volume_survey[6 * item] = l.x;
        volume_survey[6 * item + 1] = l.y;
        volume_survey[6 * item + 2] = l.z;
        volume_survey[6 * item + 3] = h.x;
        volume_survey[6 * item + 4] = h.y;
        volume_survey[6 * item + 5] = h.z;
    }
}
