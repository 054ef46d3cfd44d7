#version 100
// The wind field's grid passes: Stam's stable fluids on a MAC grid. The pressure and the
// divergence live at the centres of the air's W x H cells; the velocity on the faces between
// them: u on the x faces, a grid of (W + 1) x H whose cell (i, j) is the face left of air cell
// (i, j), and v on the y faces, W x (H + 1). The divergence of a cell is then the flux through
// its four faces, and the projection's gradient sits on the faces too, so a pressure solving the
// 5-point Poisson equation exactly leaves no divergence at all (a collocated grid's central
// differences leave about half). One define a pass (es2particles/scenes/wind.py declares which);
// X_FACES or Y_FACES says which component a face pass writes. The float64 reference of the
// tests: tests/wind_reference.py.
//
// A face is blocked (its texture u_xblocked / u_yblocked: r > 0.5) where it lies on a closed
// wall or beside an obstacle: its velocity is 0. u_walls: each side's kind (left, right, bottom,
// top): 0 slip, 1 no-slip, 2 open, 3 a no-slip wall moving along itself at u_wall_speed (+y for
// the left and right walls, +x for the bottom and top). u_cell: a cell's size (dx, dy) in
// metres; u_dt: the step in seconds.

#define WALL_SLIP 0.0
#define WALL_NOSLIP 1.0
#define WALL_OPEN 2.0

#ifdef X_FACES
#define OWN_BLOCKED u_xblocked
#define own_at u_at
#define sample_own sample_u
#define ahead_own_at u_ahead_at
#define sample_ahead_own sample_u_ahead
#define behind_own_at u_behind_at
#define held_own_at u_held_at
#define OWN_SIZE u_xfaces_size
#define OWN_BOX u_xfaces_box
#define AXIS x
#endif
#ifdef Y_FACES
#define OWN_BLOCKED u_yblocked
#define own_at v_at
#define sample_own sample_v
#define ahead_own_at v_ahead_at
#define sample_ahead_own sample_v_ahead
#define behind_own_at v_behind_at
#define held_own_at v_held_at
#define OWN_SIZE u_yfaces_size
#define OWN_BOX u_yfaces_box
#define AXIS y
#endif

#ifdef OWN_BLOCKED
bool blocked(vec2 face)
{
    return texture2D(OWN_BLOCKED, (face + 0.5) / OWN_SIZE).r > 0.5;
}
#endif

#ifdef SOLID
bool solid(vec2 cell)
{
    return texture2D(u_solid, (cell + 0.5) / u_air_size).r > 0.5;
}
#endif

#if defined(ADVECT) || defined(AHEAD) || defined(BEHIND) || defined(CORRECT)
// The wind at a world point: u from the x faces, v from the y faces, each bilinear.
vec2 wind_sample(vec2 x)
{
    return vec2(sample_u(x), sample_v(x));
}
#endif

#ifdef PRESSURE_NEIGHBOURS
// The pressure beyond the face between air cell c and its neighbour c + d (own pressure p): the
// neighbour's in fluid; p across a closed wall or at an obstacle (the face is blocked: no
// gradient acts there); -p across an open side (zero pressure on the face).
float pressure_near(vec2 c, vec2 d, float p)
{
    vec2 n = c + d;
    if (n.x < 0.0 || n.y < 0.0 || n.x >= u_air_size.x || n.y >= u_air_size.y) {
        float kind = n.x < 0.0 ? u_walls.x : n.x >= u_air_size.x ? u_walls.y
                   : n.y < 0.0 ? u_walls.z : u_walls.w;
        return kind == WALL_OPEN ? -p : p;
    }
    return solid(n) ? p : pressure_at(n);
}
#endif

#ifdef VISCOSITY
// The velocity component of the face beside ``face`` (offset d) for the viscous stencil: its
// own grid's value (a blocked one is 0: a still obstacle); beyond the wall the component runs
// along, the wall's tangential ghost (slip: the same, no-slip: opposite, moving: 2 s - it);
// beyond the walls it runs across, the last face's (zero gradient).
float own_near(vec2 face, vec2 d, float value)
{
    vec2 n = face + d;
#ifdef X_FACES
    bool along = n.y < 0.0 || n.y >= OWN_SIZE.y;  // past the bottom or top: u is tangential
    float kind = n.y < 0.0 ? u_walls.z : u_walls.w;
    float speed = n.y < 0.0 ? u_wall_speed.z : u_wall_speed.w;
#else
    bool along = n.x < 0.0 || n.x >= OWN_SIZE.x;  // past the left or right: v is tangential
    float kind = n.x < 0.0 ? u_walls.x : u_walls.y;
    float speed = n.x < 0.0 ? u_wall_speed.x : u_wall_speed.y;
#endif
    if (along) {
        return kind == WALL_SLIP || kind == WALL_OPEN ? value
             : kind == WALL_NOSLIP ? -value : 2.0 * speed - value;
    }
    return own_at(n);  // clamped to the grid: zero gradient across the walls it meets
}
#endif

#ifdef CURL
// The wind at air cell c's centre, from its faces (edge cells repeat).
vec2 centre_wind(vec2 c)
{
    c = clamp(c, vec2(0.0), u_air_size - 1.0);
    return vec2(u_at(c) + u_at(c + vec2(1.0, 0.0)), v_at(c) + v_at(c + vec2(0.0, 1.0))) * 0.5;
}
#endif

#ifdef VORTICITY
// Vorticity confinement's force at air cell c: epsilon h (N x w), N the unit gradient of |w|.
vec2 confinement(vec2 c)
{
    c = clamp(c, vec2(0.0), u_air_size - 1.0);
    float w = curl_at(c);
    vec2 grad = vec2(abs(curl_at(c + vec2(1.0, 0.0))) - abs(curl_at(c - vec2(1.0, 0.0))),
                     abs(curl_at(c + vec2(0.0, 1.0))) - abs(curl_at(c - vec2(0.0, 1.0))))
                / (2.0 * u_cell);
    vec2 n = grad / (length(grad) + 1e-6);
    return u_vorticity * min(u_cell.x, u_cell.y) * vec2(n.y * w, -n.x * w);
}
#endif

void main()
{
    vec2 c = grid_cell();
#if defined(ADVECT) || defined(AHEAD)
    // the velocity arriving here along the flow: own(x - dt u(x)), bilinear
    vec2 x = grid_point();
    write(blocked(c) ? 0.0 : sample_own(x - u_dt * wind_sample(x)));  // or the ahead field
#endif
#ifdef BEHIND
    // the ahead field carried back: ahead(x + dt u(x))
    vec2 x = grid_point();
    write(blocked(c) ? 0.0 : sample_ahead_own(x + u_dt * wind_sample(x)));
#endif
#ifdef CORRECT
    // MacCormack: ahead + (own - behind) / 2, limited to the four faces the backtrace lands among
    vec2 x = grid_point();
    vec2 g = (x - u_dt * wind_sample(x) - OWN_BOX.xy) / (OWN_BOX.zw - OWN_BOX.xy) * OWN_SIZE - 0.5;
    vec2 i = floor(g);
    float a = own_at(i), b = own_at(i + vec2(1.0, 0.0));
    float e = own_at(i + vec2(0.0, 1.0)), f = own_at(i + vec2(1.0, 1.0));
    float value = ahead_own_at(c) + 0.5 * (own_at(c) - behind_own_at(c));
    write(blocked(c) ? 0.0 : clamp(value, min(min(a, b), min(e, f)), max(max(a, b), max(e, f))));
#endif
#ifdef CURL
    // at air cell centres, from the wind there
    vec2 r = centre_wind(c + vec2(1.0, 0.0)), l = centre_wind(c - vec2(1.0, 0.0));
    vec2 t = centre_wind(c + vec2(0.0, 1.0)), b = centre_wind(c - vec2(0.0, 1.0));
    write_curl((r.y - l.y) / (2.0 * u_cell.x) - (t.x - b.x) / (2.0 * u_cell.y));
#endif
#ifdef FORCE
    // gusts: the wind's body force, varying in time; the pointer's drag pulls the air within
    // u_drag_at.z of (x, y) toward its velocity (u_drag_at.w: how much, 0 off)
    float own = own_at(c);
    vec2 x = grid_point();
    vec2 force = u_force * (1.0 + u_gusts.x * sin(6.283185307 * u_step * u_dt / u_gusts.y));
#ifdef VORTICITY
    // the mean of the two air cells' confinement the face lies between
#ifdef X_FACES
    force += 0.5 * (confinement(c - vec2(1.0, 0.0)) + confinement(c));
#else
    force += 0.5 * (confinement(c - vec2(0.0, 1.0)) + confinement(c));
#endif
#endif
    float near = exp(-dot(x - u_drag_at.xy, x - u_drag_at.xy) / (u_drag_at.z * u_drag_at.z));
    float dragged = own + near * u_drag_at.w * (u_drag_velocity.AXIS - own);
    write(blocked(c) ? 0.0 : dragged + u_dt * force.AXIS);
#endif
#ifdef HOLD
    write(own_at(c));  // the velocity before diffusion: what the iterations solve from
#endif
#ifdef VISCOSITY
    // (1 + 2 ax + 2 ay) w - ax (left + right) - ay (down + up) = held, a = nu dt / d^2
    float own = own_at(c);
    vec2 a = u_viscosity * u_dt / (u_cell * u_cell);
    float sum = a.x * (own_near(c, vec2(1.0, 0.0), own) + own_near(c, vec2(-1.0, 0.0), own))
                + a.y * (own_near(c, vec2(0.0, 1.0), own) + own_near(c, vec2(0.0, -1.0), own));
    write(blocked(c) ? 0.0 : (held_own_at(c) + sum) / (1.0 + 2.0 * a.x + 2.0 * a.y));
#endif
#ifdef DIVERGENCE
    // the net flux out of the cell through its four faces
    write_divergence(solid(c) ? 0.0 : (u_at(c + vec2(1.0, 0.0)) - u_at(c)) / u_cell.x
                                      + (v_at(c + vec2(0.0, 1.0)) - v_at(c)) / u_cell.y);
#endif
#ifdef PRESSURE
    // (l + r - 2p) / dx^2 + (b + t - 2p) / dy^2 = divergence, for p from last iteration's
    float p = pressure_at(c);
    vec2 k = 1.0 / (u_cell * u_cell);
    float sum = k.x * (pressure_near(c, vec2(1.0, 0.0), p) + pressure_near(c, vec2(-1.0, 0.0), p))
                + k.y * (pressure_near(c, vec2(0.0, 1.0), p) + pressure_near(c, vec2(0.0, -1.0), p));
    write_pressure(solid(c) ? 0.0 : (sum - divergence_at(c)) / (2.0 * k.x + 2.0 * k.y));
#endif
#ifdef PROJECT
    // the face's velocity less the pressure's difference across it: face (i, j) of the x faces
    // lies between air cells (i - 1, j) and (i, j); face (i, j) of the y faces between (i, j - 1)
    // and (i, j). Beyond an open side the pressure is the ghost's, -p (a closed side's face is
    // blocked).
#ifdef X_FACES
    vec2 d = vec2(1.0, 0.0);
#else
    vec2 d = vec2(0.0, 1.0);
#endif
    bool first = c.AXIS >= 1.0, second = c.AXIS < u_air_size.AXIS;
    float p_second = second ? pressure_at(c) : 0.0;
    float p_first = first ? pressure_at(c - d) : -p_second;
    if (!second) {
        p_second = -p_first;
    }
    write(blocked(c) ? 0.0 : own_at(c) - (p_second - p_first) / u_cell.AXIS);
#endif
#ifdef CENTRES
    // the wind at each air cell's centre: the mean of its faces (what is saved and drawn)
    write_wind(solid(c) ? vec2(0.0) : vec2(u_at(c) + u_at(c + vec2(1.0, 0.0)),
                                           v_at(c) + v_at(c + vec2(0.0, 1.0))) * 0.5);
#endif
}
