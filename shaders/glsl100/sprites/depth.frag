#version 100
// The opaque scene's distance, packed, for a context that cannot sample a depth buffer (ES 2.0
// without OES_depth_texture): each mesh drawn again (sprites/mesh.vert) into an RGBA8 target,
// depth-tested, writing its distance over the camera's far plane in 16 bits (lib/pack.glsl);
// cleared to the far plane. lib/depth.glsl reads it back.
precision highp float;
#include "lib/pack.glsl"
#include "lib/depth.glsl"

void main()
{
    gl_FragColor = vec4(pack16(view_distance(gl_FragCoord.z) / u_planes.y), 0.0, 1.0);
}
