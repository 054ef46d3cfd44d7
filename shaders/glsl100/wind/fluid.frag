#version 100
// The wind field's grid passes: Stam's stable fluids on a MAC grid. The pressure and the
// divergence live at the centres of the air's W x H cells; the velocity on the faces between
// them: u on the x faces, a grid of (W + 1) x H whose cell (i, j) is the face left of air cell
// (i, j), and v on the y faces, W x (H + 1). The divergence of a cell is then the flux through
// its four faces, and the projection's gradient sits on the faces too, so a pressure solving the
// 5-point Poisson equation exactly leaves no divergence at all (a collocated grid's central
// differences leave about half). One define a pass (es2particles/scenes/air.py declares which);
// X_FACES or Y_FACES says which component a face pass writes. The float64 reference of the
// tests: tests/wind_reference.py.
//
// DIMENSIONS 3: the same on W x H x D cells (3D grids, atlases of slices): w on the z faces,
// W x H x (D + 1), Z_FACES; the divergence, the 7-point Poisson equation, the curl (a vector)
// and its confinement take the third axis; u_walls_z: the back and front sides' kinds; MacCormack's
// limiter, the 8 values around a backtrace. Viscosity, moving walls and the pointer's drag are
// the 2D scene's alone. CARRY carries the fire (density, temperature) at the air's centres and
// feeds it at a burner (by MacCormack's scheme: FIRE_AHEAD, FIRE_BEHIND, then CARRY with
// CORRECT); BUOYANCY lifts the y faces by its temperature (the flame's wind source,
// scenes/flame.py).
//
// A face is blocked (its texture u_xblocked / u_yblocked: r > 0.5) where it lies on a closed
// wall or beside an obstacle: its velocity is 0. u_walls: each side's kind (left, right, bottom,
// top): 0 slip, 1 no-slip, 2 open, 3 a no-slip wall moving along itself at u_wall_speed (+y for
// the left and right walls, +x for the bottom and top). u_cell: a cell's size (dx, dy) in
// metres; u_dt: the step in seconds.

#define WALL_SLIP 0.0
#define WALL_NOSLIP 1.0
#define WALL_OPEN 2.0

#ifndef DIMENSIONS
#define DIMENSIONS 2
#endif
#if DIMENSIONS == 3
#if defined(VISCOSITY) || defined(HOLD)
#error "viscosity is the 2D wind's (scenes/air.py refuses it in 3D)"
#endif
#define vecd vec3
#define EX vec3(1.0, 0.0, 0.0)
#define EY vec3(0.0, 1.0, 0.0)
#define EZ vec3(0.0, 0.0, 1.0)
#define CORNERS 8
#define OWN_LO OWN_CORNER_LO
#define OWN_HI OWN_CORNER_HI
#else
#if defined(CARRY) || defined(FIRE_AHEAD) || defined(FIRE_BEHIND) || defined(Z_FACES)
#error "the fire and the z faces are the 3D air's (DIMENSIONS 3)"
#endif
#define vecd vec2
#define EX vec2(1.0, 0.0)
#define EY vec2(0.0, 1.0)
#define CORNERS 4
#define OWN_LO OWN_BOX.xy
#define OWN_HI OWN_BOX.zw
#endif

// What a carrying pass moves (the velocity component of its faces, or the fire), and where it
// is held at 0 (a blocked face, a solid cell).
#define OWN_TYPE float
#define HELD(c) blocked(c)

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
#define OWN_CORNER_LO u_xfaces_lo
#define OWN_CORNER_HI u_xfaces_hi
#define OWN_UV xfaces_uv
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
#define OWN_CORNER_LO u_yfaces_lo
#define OWN_CORNER_HI u_yfaces_hi
#define OWN_UV yfaces_uv
#define AXIS y
#endif
#ifdef Z_FACES
#define OWN_BLOCKED u_zblocked
#define own_at w_at
#define sample_own sample_w
#define ahead_own_at w_ahead_at
#define sample_ahead_own sample_w_ahead
#define behind_own_at w_behind_at
#define OWN_SIZE u_zfaces_size
#define OWN_CORNER_LO u_zfaces_lo
#define OWN_CORNER_HI u_zfaces_hi
#define OWN_UV zfaces_uv
#define AXIS z
#endif
#if defined(FIRE_AHEAD) || defined(FIRE_BEHIND) || defined(CARRY)
#undef OWN_TYPE
#undef HELD
#define OWN_TYPE vec2
#define HELD(c) solid(c)
#define own_at fire_at
#define sample_own sample_fire
#define ahead_own_at fire_ahead_at
#define sample_ahead_own sample_fire_ahead
#define behind_own_at fire_behind_at
#define OWN_SIZE u_air_size
#define OWN_CORNER_LO u_air_lo
#define OWN_CORNER_HI u_air_hi
#endif

#ifdef OWN_BLOCKED
bool blocked(vecd face)
{
    return texture2D(OWN_BLOCKED, OWN_UV(face)).r > 0.5;
}
#endif

#ifdef SOLID
bool solid(vecd cell)
{
    return texture2D(u_solid, air_uv(cell)).r > 0.5;
}
#endif

#if defined(ADVECT) || defined(AHEAD) || defined(BEHIND) || defined(CORRECT) || defined(CARRY) || defined(FIRE_AHEAD) || defined(FIRE_BEHIND)
// The wind at a world point: u from the x faces, v from the y faces (w from the z faces), each
// bilinear (trilinear).
vecd wind_sample(vecd x)
{
#if DIMENSIONS == 3
    return vec3(sample_u(x), sample_v(x), sample_w(x));
#else
    return vec2(sample_u(x), sample_v(x));
#endif
}
#endif

#ifdef PRESSURE_NEIGHBOURS
// The pressure beyond the face between air cell c and its neighbour c + d (own pressure p): the
// neighbour's in fluid; p across a closed wall or at an obstacle (the face is blocked: no
// gradient acts there); -p across an open side (zero pressure on the face).
float pressure_near(vecd c, vecd d, float p)
{
    vecd n = c + d;
#if DIMENSIONS == 3
    if (n.z < 0.0 || n.z >= u_air_size.z) {
        return (n.z < 0.0 ? u_walls_z.x : u_walls_z.y) == WALL_OPEN ? -p : p;
    }
#endif
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

#if defined(CURL) || defined(CENTRES)
// The wind at air cell c's centre, from its faces (edge cells repeat).
vecd centre_wind(vecd c)
{
    c = clamp(c, vecd(0.0), u_air_size - 1.0);
#if DIMENSIONS == 3
    return vec3(u_at(c) + u_at(c + EX), v_at(c) + v_at(c + EY), w_at(c) + w_at(c + EZ)) * 0.5;
#else
    return vec2(u_at(c) + u_at(c + vec2(1.0, 0.0)), v_at(c) + v_at(c + vec2(0.0, 1.0))) * 0.5;
#endif
}
#endif

#if defined(VORTICITY) && DIMENSIONS == 3
// Vorticity confinement's force at air cell c: epsilon h (N x w), N the unit gradient of |w|,
// w the curl (a vector in 3D), h the smallest side of a cell.
vec3 confinement(vec3 c)
{
    c = clamp(c, vec3(0.0), u_air_size - 1.0);
    vec3 grad = vec3(length(curl_at(c + EX)) - length(curl_at(c - EX)),
                     length(curl_at(c + EY)) - length(curl_at(c - EY)),
                     length(curl_at(c + EZ)) - length(curl_at(c - EZ))) / (2.0 * u_cell);
    vec3 n = grad / (length(grad) + 1e-6);
    return u_vorticity * min(min(u_cell.x, u_cell.y), u_cell.z) * cross(n, curl_at(c));
}
#elif defined(VORTICITY)
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

#ifdef CORRECT
// MacCormack's correction at c, whose point is x: ahead + (own - behind) / 2, limited to the
// values the backtrace from x lands among (4 faces or cells in 2D, 8 in 3D), found as c less
// the step's displacement in cells: where the air is still, exactly c's own.
OWN_TYPE corrected(vecd c, vecd x)
{
    vecd i = floor(c - u_dt * wind_sample(x) * OWN_SIZE / (OWN_HI - OWN_LO));
    OWN_TYPE lo = own_at(i), hi = lo;
    for (int k = 1; k < CORNERS; k++) {
        float f = float(k);
#if DIMENSIONS == 3
        OWN_TYPE value = own_at(i + vec3(mod(f, 2.0), mod(floor(f / 2.0), 2.0), floor(f / 4.0)));
#else
        OWN_TYPE value = own_at(i + vec2(mod(f, 2.0), floor(f / 2.0)));
#endif
        lo = min(lo, value);
        hi = max(hi, value);
    }
    return clamp(ahead_own_at(c) + 0.5 * (own_at(c) - behind_own_at(c)), lo, hi);
}
#endif

#ifdef CARRY
#include "lib/noise.glsl"
#endif

void main()
{
    vecd c = grid_cell();
#if defined(ADVECT) || defined(AHEAD) || defined(FIRE_AHEAD)
    // the velocity (the fire) arriving here along the flow: own(x - dt u(x)), bi-(tri)linear
    vecd x = grid_point();
    write(HELD(c) ? OWN_TYPE(0.0) : sample_own(x - u_dt * wind_sample(x)));  // or the ahead
#endif
#if defined(BEHIND) || defined(FIRE_BEHIND)
    // the ahead field carried back: ahead(x + dt u(x))
    vecd x = grid_point();
    write(HELD(c) ? OWN_TYPE(0.0) : sample_ahead_own(x + u_dt * wind_sample(x)));
#endif
#if defined(CORRECT) && !defined(CARRY)
    vecd x = grid_point();
    write(HELD(c) ? OWN_TYPE(0.0) : corrected(c, x));
#endif
#if defined(CURL) && DIMENSIONS == 3
    // at air cell centres, from the wind there: (dw/dy - dv/dz, du/dz - dw/dx, dv/dx - du/dy)
    vec3 r = centre_wind(c + EX), l = centre_wind(c - EX);
    vec3 t = centre_wind(c + EY), b = centre_wind(c - EY);
    vec3 f = centre_wind(c + EZ), k = centre_wind(c - EZ);
    vec3 h = 2.0 * u_cell;
    write_curl(vec3((t.z - b.z) / h.y - (f.y - k.y) / h.z, (f.x - k.x) / h.z - (r.z - l.z) / h.x,
                    (r.y - l.y) / h.x - (t.x - b.x) / h.y));
#elif defined(CURL)
    // at air cell centres, from the wind there
    vec2 r = centre_wind(c + vec2(1.0, 0.0)), l = centre_wind(c - vec2(1.0, 0.0));
    vec2 t = centre_wind(c + vec2(0.0, 1.0)), b = centre_wind(c - vec2(0.0, 1.0));
    write_curl((r.y - l.y) / (2.0 * u_cell.x) - (t.x - b.x) / (2.0 * u_cell.y));
#endif
#ifdef FORCE
    // gusts: the wind's body force, varying in time; the pointer's drag pulls the air within
    // u_drag_at.z of (x, y) toward its velocity (u_drag_at.w: how much, 0 off)
    float own = own_at(c);
    vecd x = grid_point();
    vecd force = u_force * (1.0 + u_gusts.x * sin(6.283185307 * u_step * u_dt / u_gusts.y));
#if defined(X_FACES)
    vecd d = EX;
#elif defined(Y_FACES)
    vecd d = EY;
#else
    vecd d = EZ;
#endif
#ifdef VORTICITY
    // the mean of the two air cells' confinement the face lies between
    force += 0.5 * (confinement(c - d) + confinement(c));
#endif
#ifdef BUOYANCY
    // hot air rises: u_buoyancy (m/s^2 at temperature 1) times the fire's temperature, the
    // mean of the two air cells the face lies between (one past the top and bottom: clamped)
    force.AXIS += u_buoyancy * 0.5 * (fire_at(c - d).y + fire_at(c).y);
#endif
#if DIMENSIONS == 3
    float dragged = own;
#else
    float near = exp(-dot(x - u_drag_at.xy, x - u_drag_at.xy) / (u_drag_at.z * u_drag_at.z));
    float dragged = own + near * u_drag_at.w * (u_drag_velocity.AXIS - own);
#endif
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
    // the net flux out of the cell through its four (six) faces
    float flux = (u_at(c + EX) - u_at(c)) / u_cell.x + (v_at(c + EY) - v_at(c)) / u_cell.y;
#if DIMENSIONS == 3
    flux += (w_at(c + EZ) - w_at(c)) / u_cell.z;
#endif
    write_divergence(solid(c) ? 0.0 : flux);
#endif
#ifdef PRESSURE
    // (l + r - 2p) / dx^2 + (b + t - 2p) / dy^2 = divergence, for p from last iteration's
    float p = pressure_at(c);
    vecd k = 1.0 / (u_cell * u_cell);
    float sum = k.x * (pressure_near(c, EX, p) + pressure_near(c, -EX, p))
                + k.y * (pressure_near(c, EY, p) + pressure_near(c, -EY, p));
#if DIMENSIONS == 3
    // (7 points: the z neighbours too)
    sum += k.z * (pressure_near(c, EZ, p) + pressure_near(c, -EZ, p));
    float diagonal = 2.0 * k.x + 2.0 * k.y + 2.0 * k.z;
#else
    float diagonal = 2.0 * k.x + 2.0 * k.y;
#endif
    write_pressure(solid(c) ? 0.0 : (sum - divergence_at(c)) / diagonal);
#endif
#ifdef PROJECT
    // the face's velocity less the pressure's difference across it: face (i, j) of the x faces
    // lies between air cells (i - 1, j) and (i, j); face (i, j) of the y faces between (i, j - 1)
    // and (i, j). Beyond an open side the pressure is the ghost's, -p (a closed side's face is
    // blocked).
#if defined(X_FACES)
    vecd d = EX;
#elif defined(Y_FACES)
    vecd d = EY;
#else
    vecd d = EZ;
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
    write_wind(solid(c) ? vecd(0.0) : centre_wind(c));
#endif
#ifdef CARRY
    // the fire (density, temperature) arriving here along the flow, fire(x - dt u(x)),
    // trilinear (or MacCormack's correction of it), each part keeping u_keep of itself a step
    // (it fades and cools); fed at the burner, a flat ball at u_burner.xyz of radius u_burner.w
    // (half as high), where each rises to u_feed flickering by noise, up to 0.7 of it, that
    // drifts with time (its puffs).
    vecd x = grid_point();
#ifdef CORRECT
    vec2 fire = corrected(c, x) * u_keep;
#else
    vec2 fire = sample_fire(x - u_dt * wind_sample(x)) * u_keep;
#endif
    vecd r = (x - u_burner.xyz) / (u_burner.w * vec3(1.0, 0.5, 1.0));
    float inside = 1.0 - smoothstep(0.7, 1.0, length(r));
    float flicker = 1.0 - 0.7 * (0.5 + 0.5 * simplex3(vec3(2.5 * x.xz, u_step * u_dt * 4.0)).w);
    write_fire(solid(c) ? vec2(0.0) : max(fire, inside * flicker * u_feed));
#endif
}
