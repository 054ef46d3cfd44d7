// The opacity shadow map (Kim and Neumann 2001, as the Mali smoke sample): the particles seen from
// the light, their opacity summed per layer of depth into one RGBA texture, layer k in channel k
// (four layers, one render target, one pass: es2particles/render/shadow.py, sprites/shadow.vert). A
// particle is lit by exp(-extinction * the opacity in front of it): the layers nearer the light
// whole, and of its own layer the share in front of it (the layer's opacity taken as evenly
// spread through its depth), less its own sprite's share there (it does not shade itself),
// above an ambient floor. For vertex shaders (the map is fetched once per particle); numpy twin:
// es2particles/render/shadow.py, light_through(). Include lib/sprite.glsl first.
uniform mat4 u_light_view_projection;
uniform vec3 u_light_eye;
uniform vec4 u_light_axis;  // the light's unit viewing direction, and the depth of layer 0's front
uniform vec4 u_light_size;  // sprite pixels in the map at distance 1, size spread, size range
uniform vec4 u_shadow;  // depth of the four layers, 1 / (opacity unit), extinction, ambient
uniform float u_shadow_size;  // the map's side in pixels
uniform float u_shadow_opacity;  // a sprite's opacity at its centre, in units of the map
uniform sampler2D u_shadow_map;
uniform sampler2D u_shadow_sprite;  // the sprite texture (its alpha is the footprint)

// Depth from the light in layers: [0, 4) inside the layered slab.
float shadow_layer(vec3 p)
{
    return clamp((dot(p - u_light_eye, u_light_axis.xyz) - u_light_axis.w) / u_shadow.x * 4.0,
                 0.0, 3.999);
}

// A particle's point size in the map (as the map's pass draws it).
float shadow_point_size(vec3 p, vec2 texel, vec2 life)
{
    float size = u_light_size.x * sprite_scale(texel, life, u_light_size.y)
        / max(distance(u_light_eye, p), 1e-6);
    return clamp(size, u_light_size.z, u_light_size.w);
}

// The opacity in front of the particle at state texel `texel`, and the light through it.
float shadow_light(vec3 p, vec2 texel, vec2 life)
{
    vec4 clip = u_light_view_projection * vec4(p, 1.0);
    vec2 pixel = (clip.xy / clip.w * 0.5 + 0.5) * u_shadow_size;  // the sprite's centre
    vec2 centre = floor(pixel) + 0.5;  // of the map texel fetched (NEAREST)
    vec4 opacity = texture2D(u_shadow_map, centre / u_shadow_size);
    float layer = shadow_layer(p);
    // What the particle's own sprite added to that texel: its alpha where the texel's centre
    // falls on it (gl_PointCoord's t runs down the window), times its opacity.
    vec2 point = (centre - pixel) / shadow_point_size(p, texel, life);
    float inside = step(abs(point.x), 0.5) * step(abs(point.y), 0.5);
    float own = inside * texture2D(u_shadow_sprite, vec2(0.5 + point.x, 0.5 - point.y)).a
        * life_fade(life) * u_shadow_opacity;
    float before = dot(opacity, clamp(vec4(layer) - vec4(0.0, 1.0, 2.0, 3.0), 0.0, 1.0))
        - fract(layer) * own;
    return mix(u_shadow.w, 1.0, exp(-u_shadow.z * u_shadow.y * max(before, 0.0)));
}
