// The opacity shadow map (Kim and Neumann 2001, as the Mali smoke sample): the particles seen from
// the light, their opacity summed per layer of depth into one RGBA texture, layer k in channel k
// (four layers, one render target, one pass: es2particles/shadow.py, sprites/shadow.vert). A
// particle is lit by exp(-extinction * the opacity in front of it): the layers nearer the light
// whole, and of its own layer the share in front of it (the layer's opacity taken as evenly
// spread through its depth), above an ambient floor. For vertex shaders (the map is fetched once
// per particle); numpy twin: es2particles/shadow.py, light_through().
uniform mat4 u_light_view_projection;
uniform vec3 u_light_eye;
uniform vec4 u_light_axis;  // the light's unit viewing direction, and the depth of layer 0's front
uniform vec4 u_shadow;  // depth of the four layers, 1 / (opacity unit), extinction, ambient
uniform sampler2D u_shadow_map;

// Depth from the light in layers: [0, 4) inside the layered slab.
float shadow_layer(vec3 p)
{
    return clamp((dot(p - u_light_eye, u_light_axis.xyz) - u_light_axis.w) / u_shadow.x * 4.0,
                 0.0, 3.999);
}

float shadow_light(vec3 p)
{
    vec4 clip = u_light_view_projection * vec4(p, 1.0);
    vec4 opacity = texture2D(u_shadow_map, clip.xy / clip.w * 0.5 + 0.5);
    float layer = shadow_layer(p);
    float before = dot(opacity, clamp(vec4(layer) - vec4(0.0, 1.0, 2.0, 3.0), 0.0, 1.0));
    return mix(u_shadow.w, 1.0, exp(-u_shadow.z * u_shadow.y * before));
}
