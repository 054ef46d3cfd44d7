#version 100
// The liquid's metaballs, last step (the author's liquid pass, its constants kept): the surface
// u_surface (the threshold, blurred twice) over the background. Inside (alpha >= 0.1): a normal
// from the alpha's gradient, the background refracted along it by the Fresnel term, a shadow
// that deepens towards the rim, the liquid's colour blended over, Lambert and a specular
// highlight (shininess 10) from a light above the screen. Outside: the background, darkened
// by the surface's soft rim (a shadow the liquid casts).
precision mediump float;
varying vec2 v_uv;
uniform sampler2D u_surface;
uniform sampler2D u_background;
uniform vec4 u_colour;   // the liquid's colour and how much of it covers the background
uniform vec2 u_texel;    // one texel of the surface's buffer

const vec3 LIGHT = vec3(0.0, 0.0, 10.0);
const vec3 CAMERA = vec3(0.0, 0.0, 5.0);
const vec3 SPECULAR = vec3(0.3);
const float SHININESS = 10.0;
const vec3 SHADOW = vec3(0.1);
const float THICKNESS = 2.0;  // how far the refraction reaches, in uv along the normal

float fresnel(vec3 normal, vec3 eye)
{
    return clamp(abs(dot(normal, eye)), 0.0, 1.0);
}

vec4 over(vec4 s, vec4 d)
{
    return s * s.a + d * (1.0 - s.a);
}

vec3 surface_normal(float centre)
{
    float right = texture2D(u_surface, v_uv + vec2(u_texel.x, 0.0)).r;
    float up = texture2D(u_surface, v_uv + vec2(0.0, u_texel.y)).r;
    return normalize(cross(vec3(max(0.1, centre), 0.0, right - centre),
                           vec3(0.0, max(0.1, centre), up - centre)));
}

vec4 inside(float alpha)
{
    vec3 vertex = vec3(2.0 * v_uv - 1.0, alpha);
    vec3 eye = normalize(CAMERA - vertex);
    vec3 normal = surface_normal(alpha);
    float f = fresnel(vertex, eye);
    vec4 colour = texture2D(u_background, v_uv + normal.xy * THICKNESS * f);
    float rim = 1.0 - alpha;
    colour = mix(colour, over(vec4(SHADOW * f, 0.5 * rim), colour), step(0.001, rim));
    colour = over(u_colour, colour);
    vec3 light = normalize(LIGHT - vertex);
    float specular = pow(max(dot(normalize(reflect(-light, normal)), eye), 0.0), SHININESS) * f;
    return vec4(colour.rgb * max(dot(light, normal), 0.0) + SPECULAR * specular, 1.0);
}

vec4 outside(float alpha)
{
    vec4 colour = texture2D(u_background, v_uv);
    return mix(colour, over(vec4(SHADOW, 5.0 * alpha), colour), step(0.001, alpha));
}

void main()
{
    // the surface's value is its red: post/blur.frag blurs the colour, and the discs are white
    float alpha = texture2D(u_surface, v_uv).r;
    gl_FragColor = vec4(mix(outside(alpha), inside(alpha), step(0.1, alpha)).rgb, 1.0);
}
