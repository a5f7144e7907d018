// Copies an RGB image texture pixel for pixel (texture row y = image row y = framebuffer row
// y); the viewport has the image's size.
layout(binding = BIND_PICTURE) uniform sampler2D u_image;
out vec4 out_color;

void main() {
    out_color = vec4(texelFetch(u_image, ivec2(gl_FragCoord.xy), 0).rgb, 1.0);
}
