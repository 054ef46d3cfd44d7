// The main of every attractor pass (es2particles/scenes/attractor.py): iterate the member's
//   vec2 attractor_map(vec2 p, vec4 k)
// ITERATIONS times per step with k = u_coefficients, starting from last step's position
// (stateful) or, with RESEED (the article's way), from the texel grid spread over the position
// range, so only the coefficients carry time; u_jitter (in texels) shifts that grid, so frames
// accumulated into one image sample the plane between the texel centres. The member's file defines attractor_map() and
// then includes this file. numpy twin: Attractor.iterate().
#ifndef ITERATIONS
#define ITERATIONS 3
#endif

void main()
{
#ifdef RESEED
    vec2 p = u_position_lo.xy + (v_uv + u_jitter / u_state_size) * u_position_span.xy;
#else
    vec2 p = read_position(v_uv);
    // A non-finite position (only float formats can hold one) restarts from the grid.
    if (!(abs(p.x) < 1e30 && abs(p.y) < 1e30)) {
        p = u_position_lo.xy + v_uv * u_position_span.xy;
    }
#endif
    for (int i = 0; i < ITERATIONS; ++i) {
        p = attractor_map(p, u_coefficients);
    }
    write_position(p);
}
