// One triangle that covers the whole viewport (no vertex buffer), and texture coordinates
// that put a picture's row 0 (texture row 0) at the top of the viewport.
out vec2 v_uv;

void main() {
    vec2 corner = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
    v_uv = vec2(corner.x, 1.0 - corner.y);
}
