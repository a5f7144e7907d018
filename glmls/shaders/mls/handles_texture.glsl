// Handle storage: an RGBA32F 2D texture of vec4(p.x, p.y, q.x, q.y), scaled, row by row
// (u_handle_width texels per row), fetched without filtering.
layout(binding = BIND_HANDLE_TEXTURE) uniform sampler2D u_handle_texture;
uniform int u_handle_count;
uniform int u_handle_width;

int mls_handle_count() {
    return u_handle_count;
}

vec4 mls_handle(int i) {
    return texelFetch(u_handle_texture, ivec2(i % u_handle_width, i / u_handle_width), 0);
}
