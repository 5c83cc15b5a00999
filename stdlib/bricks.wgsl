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
    // Brick pool texels per axis (xyz) and voxels per brick edge, apron excluded (w).
    pool: vec4f,
    // x: a pixel's footprint in level-0 voxels that does not grow with distance (slice views);
    // y: added to the level a footprint asks for; z: the finest level used.
    detail: vec4f,
    // Page-table texels per row (x) and per slice (y): a brick's word in the requests.
    table: vec4u,
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
// The ray's last page-table read (its request word + 1, 0 before the first; the entry):
// consecutive samples mostly fall in one brick, so most samples read neither the table nor
// write the requests.
var<private> NAME_last: vec2u;

// The value of bricked volume NAME at `p` (normalized volume coordinates).
fn NAME_sample(p: vec3f) -> f32 {
    let grid = NAME_layout.grid.xyz;
    let levels = u32(NAME_layout.grid.w);
    let x0 = p * grid;
    let footprint = max(NAME_layout.detail.x, distance(x0, NAME_layout.eye.xyz) * NAME_layout.eye.w);
    let wanted = floor(log2(max(footprint, 1.0)) + NAME_layout.detail.y);
    var level = u32(clamp(wanted, NAME_layout.detail.z, f32(levels - 1u)));
    let edge = NAME_layout.pool.w;
    var value = 0.0;
    loop {
        let scale = exp2(f32(level));
        // Level voxels, clamped to the centres of the edge voxels as the sampler clamps.
        let x = clamp(x0 / scale, vec3f(0.5), ceil(grid / scale) - 0.5);
        let brick = min(vec3u(x / edge), NAME_layout.bricks[level].xyz - 1u);
        let texel = brick + NAME_layout.offsets[level].xyz;
        let request = texel.x + NAME_layout.table.x * (texel.y + NAME_layout.table.y * texel.z);
        if request + 1u != NAME_last.x {
            let read = textureLoad(NAME_pages, texel, 0).x;
            NAME_last = vec2u(request + 1u, read);
            // A resident brick is marked used (least recently used bricks are evicted first), a
            // missing one needed.
            NAME_requests[request] = select(1u, 2u, (read >> 30u) == 1u);
        }
        let entry = NAME_last.y;
        let kind = entry >> 30u;
        if kind == 1u {
            // The slot's position in the pool (10 bits an axis); its first texel is the apron
            // before the brick's first voxel.
            let slot = vec3u((entry >> 20u) & 1023u, (entry >> 10u) & 1023u, entry & 1023u);
            let q = vec3f(slot) * (edge + 2.0) + 1.0 + (x - vec3f(brick) * edge);
            value = textureSampleLevel(NAME, NAME_sampler, q / NAME_layout.pool.xyz, 0.0).x;
            break;
        }
        if kind == 2u {
            // A brick of one value, in 30-bit fixed point.
            value = f32(entry & 0x3fffffffu) / 1073741823.0;
            break;
        }
        // Missing: the next coarser level answers (the coarsest is always resident; past it, 0).
        level += 1u;
        if level >= levels {
            break;
        }
    }
    return value;
}

// Level-0 voxels per axis of bricked volume NAME: what `dims(v)` gives.
fn NAME_dims() -> vec3u {
    return vec3u(NAME_layout.grid.xyz);
}
