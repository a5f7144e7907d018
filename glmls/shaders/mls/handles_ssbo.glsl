// Handle storage: a std430 shader storage buffer of vec4(p.x, p.y, q.x, q.y), scaled.
layout(std430, binding = BIND_HANDLES) readonly buffer MLSHandles {
    vec4 mls_handles[];
};
uniform int u_handle_count;

int mls_handle_count() {
    return u_handle_count;
}

vec4 mls_handle(int i) {
    return mls_handles[i];
}
