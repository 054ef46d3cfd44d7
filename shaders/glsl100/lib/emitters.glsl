// Point emitters (es2particles/scenes/emitter.py: PointEmitters): a particle's emitter chosen by
// a hash of its texel against the emitters' cumulative shares, and its launch from it: the "up"
// speed along the emitter's direction, the "across" speed at a random azimuth around it.
// Uniforms, declared by the graph from the scene's values (PointEmitting.uniforms):
// u_emitters[2 EMITTERS] (per emitter: its point and the cumulative share of the particles up to
// it, then its direction), u_speed (across min, max, up min, max). Include lib/life.glsl first
// (hash44).

// The emitter of the particle at ``uv``: its point (xyz) and direction (out).
vec3 emitter_of(vec2 uv, out vec3 direction)
{
    float share = hash44(vec4(floor(uv * u_state_size), 19.0, 23.0)).x;
    vec3 e = u_emitters[0].xyz;
    direction = u_emitters[1].xyz;
    for (int i = 1; i < EMITTERS; ++i) {  // ES 1.00 fragment shaders index uniforms by constants
        if (share >= u_emitters[2 * i - 2].w) {
            e = u_emitters[2 * i].xyz;
            direction = u_emitters[2 * i + 1].xyz;
        }
    }
    return e;
}

// The launch of the particle at ``uv`` from its emitter, with random numbers ``r`` (x: the
// azimuth, y: the across speed, z: the up speed): its velocity; its point in ``x``.
vec3 emitter_launch(vec2 uv, vec4 r, out vec3 x)
{
    float azimuth = 6.2831853 * r.x;
    float across = mix(u_speed.x, u_speed.y, r.y);
    vec3 up;
    x = emitter_of(uv, up);
    vec3 side = normalize(cross(up, abs(up.y) < 0.99 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0)));
    vec3 other = cross(up, side);
    return up * mix(u_speed.z, u_speed.w, r.z) + (side * cos(azimuth) + other * sin(azimuth)) * across;
}
