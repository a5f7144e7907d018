// Units u_first .. u_first + u_count - 1 of a buffer set to u_word: a unit is a word, or
// with FILL_VEC4 four words; FILL_UNITS units per invocation (glmls.gl.dispatch.fill_buffer).
// On the GPU, unlike a mapped buffer filled by the host, which crosses a discrete GPU's bus
// and waits for the buffer's last use.
layout(local_size_x = LOCAL_SIZE) in;

#ifndef FILL_VEC4
#define FILL_VEC4 0
#endif
#define FILL_UNITS 4

#if FILL_VEC4
#define FILL_UNIT uvec4
#else
#define FILL_UNIT uint
#endif

layout(std430, binding = BIND_FILL) writeonly buffer Fill {
    FILL_UNIT fill_units[];
};

uniform int u_offset;   // first unit of this dispatch
uniform int u_count;    // units to fill
uniform int u_first;    // the buffer's first unit to fill
uniform uint u_word;

void main() {
    int first = u_offset + int(gl_GlobalInvocationID.x) * FILL_UNITS;
    for (int k = 0; k < FILL_UNITS; ++k) {
        if (first + k < u_count) {
            fill_units[u_first + first + k] = FILL_UNIT(u_word);
        }
    }
}
