#version 100
// A confetti's shape, made from the quad's own coordinates (v_corner in [-1, 1]^2, the ARM
// chapter's procedural shapes): 0 a disc, 1 a square, 2 a five-pointed star; the rest of the
// quad is discarded, so the quads are opaque shapes with depth. OCCLUDER: drawn black, for the
// light shafts (render/shafts.py).
precision mediump float;
varying vec2 v_corner;
varying vec3 v_colour;
varying float v_shape;

void main()
{
    vec2 c = v_corner;
    float r = length(c);
    float inside;
    if (v_shape < 0.5) {
        inside = step(r, 1.0);
    } else if (v_shape < 1.5) {
        inside = step(max(abs(c.x), abs(c.y)), 0.8);
    } else {
        // A star: the radius swings between 0.42 and 1 five times around.
        float a = atan(c.y, c.x);
        float swing = 0.5 + 0.5 * cos(5.0 * a - 1.5707963);
        inside = step(r, mix(0.42, 1.0, swing * swing));
    }
    if (inside < 0.5) {
        discard;
    }
#ifdef OCCLUDER
    gl_FragColor = vec4(0.0, 0.0, 0.0, 1.0);  // light shafts' occluder: it stops the light
#else
    gl_FragColor = vec4(v_colour, 1.0);
#endif
}
