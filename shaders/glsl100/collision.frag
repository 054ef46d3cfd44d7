#version 100
// The collision scene's passes: one file, three passes. Each runs particle_step() on last step's
// state and writes one part of the result: WRITE_VELOCITY, WRITE_POSITION or WRITE_LIFE. The life
// pass skips the integration but reads all three quantities, to reset a non-finite particle
// exactly when the other two passes do.
precision highp float;
precision highp sampler2D;
#include "lib/particle.glsl"

varying vec2 v_uv;
uniform sampler2D u_life;
uniform vec4 u_life_range;
uniform vec4 u_out_range;
uniform sampler2D u_position;
uniform vec4 u_position_range;
uniform sampler2D u_velocity;
uniform vec4 u_velocity_range;

void main()
{
    Particle p = particle_step(state_read(u_position, v_uv, u_position_range),
                               state_read(u_velocity, v_uv, u_velocity_range),
                               state_read(u_life, v_uv, u_life_range), v_uv);
#ifdef WRITE_LIFE
    gl_FragColor = state_encode(p.life, u_out_range);
#else
#ifdef WRITE_POSITION
    gl_FragColor = state_encode(p.x, u_out_range);
#else
    gl_FragColor = state_encode(p.v, u_out_range);
#endif
#endif
}
