// Handle storage: a std140 uniform block of vec4(p.x, p.y, q.x, q.y), scaled.
// MLS_UBO_CAPACITY (a define) is the block's length: GL_MAX_UNIFORM_BLOCK_SIZE / 16 handles,
// at least 1024 (16 KB) on every GL 4.3 driver; the bound buffer is that long.
layout(std140, binding = BIND_HANDLES_BLOCK) uniform MLSHandles {
    vec4 mls_handles[MLS_UBO_CAPACITY];
};
uniform int u_handle_count;

int mls_handle_count() {
    return u_handle_count;
}

vec4 mls_handle(int i) {
    return mls_handles[i];
}
