// The lookup of a bricked volume, which `sample(v, p)` and `dims(v)` call for a volume the
// runtime keeps in bricks (`vrsc explain` shows it in place of a texture sample). `NAME` is the
// volume's uniform. A sample picks the level whose voxels are as large as the pixel's footprint
// there, finds its brick in the page table and samples the brick's pool slot; a brick that is
// not resident is requested (the runtime loads what rays asked for) and the next coarser level
// answers instead, so the picture is complete and sharpens as bricks arrive.

struct BrickLayout {
    // Level-0 voxels per axis (xyz) and the number of levels (w).
    grid: vec4f,
    // The view's eye in level-0 voxels (xyz) and the angle one pixel spans (w, radians; 0 in
    // views without perspective).
    eye: vec4f,
    // 1 / brick pool texels per axis (xyz) and voxels per brick edge, apron excluded (w).
    pool: vec4f,
    // x: a pixel's footprint in level-0 voxels that does not grow with distance (slice views);
    // y: the finest level used.
    detail: vec4f,
    // Page-table texels per row (x) and per slice (y): a brick's word in the requests.
    table: vec4u,
    // Per level: its voxels per axis (xyz) and 1 / 2^level (w).
    dims: array<vec4f, 16>,
    // Per level: where its bricks start in the page table (xyz).
    offsets: array<vec4u, 16>,
    // Per level: bricks per axis (xyz).
    bricks: array<vec4u, 16>,
}

@group(0) @binding(0) var NAME: texture_3d<f32>;
@group(0) @binding(1) var NAME_sampler: sampler;
@group(0) @binding(2) var NAME_pages: texture_3d<u32>;
@group(0) @binding(3) var<uniform> NAME_layout: BrickLayout;
@group(0) @binding(4) var<storage, read_write> NAME_requests: array<u32>;
// The brick the ray's last sample read: its box in the voxels of its level (xyz) with 1 once
// there is one (w), the box's end (xyz) with the brick's one value (w; -1 for a brick in the
// pool), its level's voxels per axis (xyz) with 1 / 2^level (w), and what turns its voxel
// position into a pool texel. The ray's next samples inside the box use it at once: they pick
// no level, read neither the page table nor the layout's per-level arrays, and write no
// request (the level changes where a ray enters another brick).
var<private> NAME_lo: vec4f;
var<private> NAME_hi: vec4f;
var<private> NAME_scale: vec4f;
var<private> NAME_shift: vec3f;

// The value of bricked volume NAME at `p` (normalized volume coordinates).
fn NAME_sample(p: vec3f) -> f32 {
    let x0 = p * NAME_layout.grid.xyz;
    // Level voxels, clamped to the centres of the edge voxels as the sampler clamps.
    var x = clamp(x0 * NAME_scale.w, vec3f(0.5), NAME_scale.xyz - 0.5);
    if NAME_lo.w == 0.0 || any(x < NAME_lo.xyz) || any(x >= NAME_hi.xyz) {
        // The level whose voxels are as large as the pixel's footprint: floor(log2(footprint))
        // from the float's exponent (footprints below 1 voxel ask for level 0).
        let footprint = max(NAME_layout.detail.x, distance(x0, NAME_layout.eye.xyz) * NAME_layout.eye.w);
        let wanted = (bitcast<u32>(max(footprint, 1.0)) >> 23u) - 127u;
        let levels = u32(NAME_layout.grid.w);
        var level = clamp(wanted, u32(NAME_layout.detail.y), levels - 1u);
        // The page table: the wanted level's brick, else the next coarser one's.
        let edge = NAME_layout.pool.w;
        loop {
            let scale = NAME_layout.dims[level];
            x = clamp(x0 * scale.w, vec3f(0.5), scale.xyz - 0.5);
            let count = NAME_layout.bricks[level].xyz;
            let brick = min(vec3u(x / edge), count - 1u);
            let texel = brick + NAME_layout.offsets[level].xyz;
            let request = texel.x + NAME_layout.table.x * (texel.y + NAME_layout.table.y * texel.z);
            let entry = textureLoad(NAME_pages, texel, 0).x;
            let kind = entry >> 30u;
            let lo = vec3f(brick) * edge;
            NAME_lo = vec4f(lo, 1.0);
            // The last brick of an axis takes what lies past its edge (clamped above).
            NAME_hi = vec4f(select(lo + edge, vec3f(1e30), brick + 1u >= count), -1.0);
            NAME_scale = scale;
            if kind == 1u {
                // Marked used: least recently used bricks are evicted first. The slot's
                // position in the pool is 10 bits an axis; its first texel is the apron before
                // the brick's first voxel.
                NAME_requests[request] = 2u;
                let slot = vec3u((entry >> 20u) & 1023u, (entry >> 10u) & 1023u, entry & 1023u);
                NAME_shift = vec3f(slot) * (edge + 2.0) + 1.0 - lo;
                break;
            }
            if kind == 2u {
                // A brick of one value, in 30-bit fixed point.
                NAME_hi.w = f32(entry & 0x3fffffffu) / 1073741823.0;
                break;
            }
            // Missing: asked for, and the next coarser level answers (the coarsest is always
            // resident; past it, 0).
            NAME_requests[request] = 1u;
            level += 1u;
            if level >= levels {
                NAME_hi.w = 0.0;
                break;
            }
        }
    }
    if NAME_hi.w >= 0.0 {
        return NAME_hi.w;
    }
    return textureSampleLevel(NAME, NAME_sampler, (x + NAME_shift) * NAME_layout.pool.xyz, 0.0).x;
}

// Level-0 voxels per axis of bricked volume NAME: what `dims(v)` gives.
fn NAME_dims() -> vec3u {
    return vec3u(NAME_layout.grid.xyz);
}
