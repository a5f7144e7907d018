// The pixel centres of every image of a batch's chunk drawn as points (``splat``) into the
// atlas of their output canvases (image k's rows k * H .. k * H + H - 1), one instance per
// image: as warp/mesh.vert.glsl (WARP_SPLAT) draws one image's. The points go in reverse
// order, so that where f folds the first source pixel in scan order is drawn last and shows;
// a point is rounded to its pixel centre before the rasterizer sees it, and a point off its
// own canvas is put past the clip volume (the single draw's viewport clips it there; in the
// atlas it would land on a neighbour's rows).
#include "batch/mesh.glsl"

uniform ivec2 u_target_size;  // W, H of one image's output canvas
uniform int u_images;         // images in the atlas

flat out ivec2 v_pixel;       // the lattice pixel
flat out int v_image;

void main() {
    int k = gl_InstanceID;
    int i = u_mesh_dims.x * u_mesh_dims.y - 1 - gl_VertexID;
    ivec2 ij = ivec2(i % u_mesh_dims.x, i / u_mesh_dims.x);
    v_pixel = ij;
    v_image = k;
    vec2 pixel = floor(batch_vertex_px(k, ij) + 0.5);
    bool inside = all(greaterThanEqual(pixel, vec2(0.0))) && all(lessThan(pixel, vec2(u_target_size)));
    vec2 atlas = vec2(u_target_size.x, u_target_size.y * u_images);
    vec2 ndc = (pixel + vec2(0.5, 0.5 + float(k * u_target_size.y))) / atlas * 2.0 - 1.0;
    gl_Position = inside ? vec4(ndc, 0.0, 1.0) : vec4(2.0, 2.0, 2.0, 1.0);
}
