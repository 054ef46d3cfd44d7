// The 3D collision field of one object: signed distance and unit normal per voxel, in a 2D slice
// atlas (slices of constant z tiled in rows), sampled in the object's own space (where
// lib/motion.glsl's motion_unplace takes a world point). numpy twins: es2particles/field3d.py
// (VoxelField.sample, octahedral_decode).
// Uniforms (VoxelField.uniforms, scenes/collision3d.py): u_field (the atlas), u_field_lo (the
// box's low corner, object space), u_voxel (a voxel's side), u_field_cells (voxels along x, y,
// z), u_field_atlas (tile width, tile height, tiles per row, -), u_field_atlas_size (texels),
// u_field_range (the distance's low end and span).
// FIELD_FLOAT: the atlas holds (distance, normal) as floats; FIELD_SMOOTH: R the distance in 8
// bits, GB the octahedral normal (for lossy block compression); else RG the distance in 16 bits
// (high, low bytes) and BA the octahedral normal.
#include "lib/pack.glsl"
#include "lib/octahedral.glsl"


// The NEAREST voxel's normal n, and its distance carried from the voxel's centre to q along n
// (exact for flat faces). Outside the field's box: far, and no normal to speak of.
void field_sample(vec3 q, out float d, out vec3 n)
{
    vec3 cell = floor((q - u_field_lo) / u_voxel);
    if (any(lessThan(cell, vec3(0.0))) || any(greaterThanEqual(cell, u_field_cells))) {
        d = u_field_range.x + u_field_range.y;
        n = vec3(0.0, 1.0, 0.0);
        return;
    }
    float row = floor((cell.z + 0.5) / u_field_atlas.z);
    vec2 texel = vec2((cell.z - row * u_field_atlas.z) * u_field_atlas.x + cell.x,
                      row * u_field_atlas.y + cell.y);
    vec4 t = texture2D(u_field, (texel + 0.5) / u_field_atlas_size);
#if defined(FIELD_FLOAT)
    d = t.x;
    n = normalize(t.yzw);
#else
    vec4 bytes = floor(t * 255.0 + 0.5);
#if defined(FIELD_SMOOTH)
    d = u_field_range.x + t.x * u_field_range.y;
    n = octahedral_decode((bytes.yz - 127.0) * (1.0 / 127.0));
#else
    d = u_field_range.x + unpack16(t.xy) * u_field_range.y;
    n = octahedral_decode((bytes.zw - 127.0) * (1.0 / 127.0));
#endif
#endif
    d += dot(n, q - (u_field_lo + (cell + 0.5) * u_voxel));
}
