// One triangle covering the viewport, with texture coordinates for a picture whose row 0
// (texture row 0, as WarpPipeline.render wrote it with flip_y = false) goes at the top.
out vec2 v_uv;

void main() {
    vec2 corner = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
    v_uv = vec2(corner.x, 1.0 - corner.y);
}
