// f of the 3D MLS (mls3/core.glsl) in source voxels, for voxels of u_volume_scale = (dx, dy,
// dz) handle units: v + d, d = f - v as the kernel computes it (exactly 0 where every handle
// in reach stays), so that the identity and translations keep their digits, plus the
// targets' offset of the kernel (u_mls3_offset, 0 but for targets far from their sources).
#include "mls3/core.glsl"

uniform vec3 u_volume_scale;

vec3 volume_f(vec3 voxel) {
    vec3 v = voxel * u_volume_scale;
    vec3 d = mls3_eval(mls3_to_scaled(v)).d * u_mls3_scale + u_mls3_offset;
    return voxel + d / u_volume_scale;
}
