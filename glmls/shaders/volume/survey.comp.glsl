// The box of f over each z layer of points of the band held in the lattice buffer: one work
// group per layer (u_offset + the group's number, from the band's first layer), its
// invocations striding over the layer's points, then a reduction in shared memory. Out:
// per layer (low x, y, z, high x, y, z), NaN left out (a layer of NaN only: +inf, -inf).
// The construction reads these few floats back instead of the lattice.
layout(local_size_x = LOCAL_SIZE) in;

#include "volume/lattice.glsl"

layout(std430, binding = BIND_VOLUME_SURVEY) writeonly buffer VolumeSurvey {
    float volume_survey[];
};

uniform int u_offset;   // the first layer of this dispatch (from the band's first)
uniform int u_count;    // layers

shared vec3 survey_low[LOCAL_SIZE];
shared vec3 survey_high[LOCAL_SIZE];

void main() {
    int layer = u_offset + int(gl_WorkGroupID.x);
    int lane = int(gl_LocalInvocationID.x);
    int points = u_lattice_dims.x * u_lattice_dims.y;
    vec3 low = vec3(uintBitsToFloat(0x7F800000u));   // +inf
    vec3 high = -low;
    if (layer < u_count) {
        int first = 3 * layer * points;
        for (int k = lane; k < points; k += LOCAL_SIZE) {
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
    if (lane == 0 && layer < u_count) {
        vec3 l = survey_low[0];
        vec3 h = survey_high[0];
        volume_survey[6 * layer] = l.x;
        volume_survey[6 * layer + 1] = l.y;
        volume_survey[6 * layer + 2] = l.z;
        volume_survey[6 * layer + 3] = h.x;
        volume_survey[6 * layer + 4] = h.y;
        volume_survey[6 * layer + 5] = h.z;
    }
}
