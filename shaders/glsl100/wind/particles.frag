#version 100
// The wind's particles, in the article's shape of a step: a velocity pass that relaxes each
// particle's velocity toward the air's (u and v bilinear from their faces at its place;
// u_relax = 1: a tracer, taking it exactly), then a position pass, and the life clock. A
// particle that dies of age, or whose step would leave the box or enter an obstacle, is born
// again at a free random place: every pass computes that alike from last step's state and this
// step's velocity, so they agree. WRITE_VELOCITY, WRITE_POSITION or WRITE_LIFE says which pass
// this is.
#include "lib/life.glsl"

#ifndef WRITE_VELOCITY
// Outside the box u_box (x0, y0, x1, y1), or in an obstacle of the mask u_solid over it.
bool blocked(vec2 x)
{
    vec2 g = (x - u_box.xy) / (u_box.zw - u_box.xy);
    if (g.x < 0.0 || g.y < 0.0 || g.x >= 1.0 || g.y >= 1.0) {
        return true;
    }
    return texture2D(u_solid, g).r > 0.5;
}

// Born again this step: of age, or moving where it cannot be.
bool reborn(vec2 x, vec2 v, vec2 life)
{
    return life_emits(life, life + vec2(u_dt, 0.0), u_dt) || blocked(x + u_dt * v);
}

// A free place: the first of eight random points in the box that no obstacle holds.
vec2 birthplace(vec2 uv)
{
    vec2 texel = floor(uv * u_state_size);
    vec2 x = u_box.xy;
    for (int i = 0; i < 8; i++) {
        x = mix(u_box.xy, u_box.zw, step_hash(texel, 1.0 + float(i)).xy);
        if (!blocked(x)) {
            break;
        }
    }
    return x;
}
#endif

void main()
{
#ifdef WRITE_VELOCITY
    vec2 v = read_velocity(v_uv);
    vec2 x = read_position(v_uv);
    write_velocity(v + u_relax * (vec2(sample_u(x), sample_v(x)) - v));
#else
    vec2 x = read_position(v_uv);
    vec2 v = read_velocity(v_uv);  // this step's
    vec2 life = read_life(v_uv);
    bool again = reborn(x, v, life);
#ifdef WRITE_POSITION
    write_position(again ? birthplace(v_uv) : x + u_dt * v);
#else
    vec4 r = life_random(v_uv);
    write_life(again ? vec2(0.0, mix(u_lifetime.x, u_lifetime.y, r.x)) : life + vec2(u_dt, 0.0));
#endif
#endif
}
