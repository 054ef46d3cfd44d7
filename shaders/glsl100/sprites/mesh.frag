#version 100
// Simple lighting from a point light: ambient plus Lambert. CHECKER: the floor's checkerboard of
// u_colour and u_colour2 in cells of u_checker world units. TEXTURED: u_colour times a texture.
// LAMP (render/lamp.py, the ARM chapter's lamp): u_light is a spot lamp looking down its
// u_lamp_view_projection; its light falls in a disc, the lamp's shape made procedurally from the
// light map's texture coordinates (full to 75% of the cone's radius, then fading to its rim),
// and is let through by the light map (u_light_map: what the particles in front let pass, and
// the object's own shadow on the floor), above u_ambient.
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
#ifdef LAMP
uniform sampler2D u_light_map;
uniform mat4 u_lamp_view_projection;
uniform float u_ambient;

// The share of the lamp's light that reaches the point: its disc times what the map lets pass.
float lamp_light(vec3 world)
{
    vec4 clip = u_lamp_view_projection * vec4(world, 1.0);
    if (clip.w <= 0.0) {
        return 0.0;
    }
    vec2 uv = clip.xy / clip.w * 0.5 + 0.5;
    float disc = 1.0 - smoothstep(0.75, 1.0, length(uv * 2.0 - 1.0));
    return disc * texture2D(u_light_map, uv).r;
}
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
#ifdef LAMP
    float light = u_ambient + (1.0 - u_ambient) * max(dot(normalize(v_normal), l), 0.0)
        * lamp_light(v_world);
#else
    float light = 0.35 + 0.65 * max(dot(normalize(v_normal), l), 0.0);
#endif
    gl_FragColor = vec4(colour * light, 1.0);
}
