#version 100
// The collision scene's passes: one file, three passes. Each runs particle_step() on last step's
// state and writes one part of the result: WRITE_VELOCITY, WRITE_POSITION or WRITE_LIFE. The life
// pass skips the integration but reads all three quantities, to reset a non-finite particle
// exactly when the other two passes do.
#include "lib/particle.glsl"

void main()
{
    Particle p = particle_step(read_position(v_uv), read_velocity(v_uv), read_life(v_uv), v_uv);
#if defined(WRITE_LIFE)
    write_life(p.life);
#elif defined(WRITE_POSITION)
    write_position(p.x);
#else
    write_velocity(p.v);
#endif
}
