// Distances from the camera, for soft particles (the ARM chapter's: a sprite fades as it nears
// the opaque scene behind it) and the depth-aware upsample of a low-resolution sprite buffer.
// u_planes: the camera's near, far and 1 for an orthographic camera (the "depth_planes" frame
// value). The scene's depth is read from its depth texture where the context can sample one
// (SCENE_DEPTH_TEXTURE: OES_depth_texture), else from an RGBA8 target a pre-pass wrote, the
// distance over far packed in 16 bits (sprites/depth.frag). Include lib/pack.glsl first.
uniform vec3 u_planes;

// A depth buffer's value (window depth in [0, 1]) as a distance along the view.
float view_distance(float window)
{
    float n = u_planes.x;
    float f = u_planes.y;
    if (u_planes.z > 0.5) {
        return n + window * (f - n);
    }
    return 2.0 * n * f / (f + n - (2.0 * window - 1.0) * (f - n));
}

#ifdef SCENE_DEPTH
uniform highp sampler2D u_scene_depth;  // highp: a default sampler may be read as half floats

// The opaque scene's distance at screen position uv (in [0, 1]^2).
float scene_distance(vec2 uv)
{
    vec4 t = texture2D(u_scene_depth, uv);
#ifdef SCENE_DEPTH_TEXTURE
    return view_distance(t.r);
#else
    return unpack16(t.rg) * u_planes.y;
#endif
}
#endif
