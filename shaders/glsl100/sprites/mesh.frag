#version 100
// Simple lighting from a point light: ambient plus Lambert. CHECKER: the floor's checkerboard of
// u_colour and u_colour2 in cells of u_checker world units. TEXTURED: u_colour times a texture.
precision mediump float;
uniform vec3 u_light;
uniform vec3 u_colour;
#ifdef CHECKER
uniform vec3 u_colour2;
uniform float u_checker;
#endif
varying vec3 v_normal;
varying vec3 v_world;
#ifdef TEXTURED
uniform sampler2D u_texture;
varying vec2 v_uv;
#endif

void main()
{
    vec3 colour = u_colour;
#ifdef TEXTURED
    colour *= texture2D(u_texture, v_uv).rgb;
#endif
#ifdef CHECKER
    vec2 cell = floor(v_world.xz / u_checker);
    colour = mod(cell.x + cell.y, 2.0) < 0.5 ? u_colour : u_colour2;
#endif
    vec3 l = normalize(u_light - v_world);
    float light = 0.35 + 0.65 * max(dot(normalize(v_normal), l), 0.0);
    gl_FragColor = vec4(colour * light, 1.0);
}
