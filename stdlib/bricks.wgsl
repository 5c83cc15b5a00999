// The lookup of a bricked volume, which `sample(v, p)` and `dims(v)` call for a volume the
// runtime keeps in bricks (`vrsc explain` shows it in place of a texture sample). `NAME` is the
// volume's uniform. A sample picks the level whose voxels are as large as the pixel's footprint
// there, finds its brick in the page table and samples the brick's pool slot; a brick that is
// not resident is requested (the runtime loads what rays asked for) and the next coarser level
// answers instead, so the picture is complete and sharpens as bricks arrive.
//
// Rays march brick by brick (see "Bricked volumes" in docs/reference.md): the first lookup of a
// sample that `NAME_segment_start` opened keeps the brick it found as the ray's segment, and the
// samples after it read that brick with `NAME_sample_in_segment`, which reads no page table and
// writes no request, until one reads outside it (`NAME_segment_missed`): the composer then
// takes that sample again with the full lookup, which opens the next segment.
//
// The full lookup has no branch to skip work (a software rasterizer such as lavapipe runs both
// sides of a branch for a group of pixels anyway), reads no per-level table (each level's
// page-table block is indexed as level 0's) and converts with signed integers (x86 has no
// vector conversions for unsigned ones). Its loop runs once unless a brick is missing.

struct BrickLayout {
    // Level-0 voxels per axis (xyz) and the number of levels (w).
    grid: vec4f,
    // The view's eye in level-0 voxels (xyz) and the square of the angle one pixel spans (w,
    // radians^2; 0 in views without perspective).
    eye: vec4f,
    // 1 / brick pool texels per axis (xyz) and voxels per brick edge, apron excluded (w).
    pool: vec4f,
    // x: the square of a pixel's footprint in level-0 voxels that does not grow with distance
    // (slice views); y: the finest level used; z: voxels of apron stored on each side of a
    // brick.
    detail: vec4f,
    // A brick's page-table entry is dot((brick xyz, level), table): 1, level 0's bricks per row,
    // per slice, and per level.
    table: vec4f,
}

@group(0) @binding(0) var NAME: texture_3d<f32>;
@group(0) @binding(1) var NAME_sampler: sampler;
@group(0) @binding(2) var<storage, read> NAME_pages: array<u32>;
@group(0) @binding(3) var<uniform> NAME_layout: BrickLayout;
@group(0) @binding(4) var<storage, read_write> NAME_requests: array<u32>;

// The ray's segment, in normalized volume coordinates: the box its samples may read (the
// wanted brick widened by what its apron holds), what turns a normalized position into pool
// texel coordinates (`to_pool`, `pool_at`) and the value of a brick of one value (x, when y is
// 1). A segment read needs no clamp to the volume: beyond the volume's last voxel a brick's
// apron and voxels repeat it, as the sampler clamps a single texture.
var<private> NAME_segment_lo: vec3f;
var<private> NAME_segment_hi: vec3f;
var<private> NAME_segment_to_pool: vec3f;
var<private> NAME_segment_pool_at: vec3f;
var<private> NAME_segment_value: vec2f;
// Whether the next full lookup opens a segment, and whether a sample read outside it.
var<private> NAME_segment_open: bool;
var<private> NAME_segment_out: bool;

// The value of bricked volume NAME at `p` (normalized volume coordinates).
fn NAME_sample(p: vec3f) -> f32 {
    let x0 = p * NAME_layout.grid.xyz;
    // The level whose voxels are as large as the pixel's footprint: floor(log2(footprint)), half
    // the exponent of the squared footprint (footprints below 1 voxel ask for level 0).
    let to_eye = x0 - NAME_layout.eye.xyz;
    let footprint2 = max(NAME_layout.detail.x, dot(to_eye, to_eye) * NAME_layout.eye.w);
    let wanted = ((bitcast<i32>(max(footprint2, 1.0)) >> 23) - 127) >> 1;
    let coarsest = i32(NAME_layout.grid.w) - 1;
    var level = min(max(wanted, i32(NAME_layout.detail.y)), coarsest);
    let edge = NAME_layout.pool.w;
    let apron = NAME_layout.detail.z;
    // The wanted brick in level-0 voxels: the segment ends where it does, so the ray asks for
    // the next one even while a coarser level answers.
    let wanted_scale = bitcast<f32>((127 - level) << 23);
    let wanted_x = clamp(x0 * wanted_scale, vec3f(0.5), ceil(NAME_layout.grid.xyz * wanted_scale) - 0.5);
    let wanted_lo = floor(wanted_x * (1.0 / edge)) * edge / wanted_scale;
    var x: vec3f;
    var lo: vec3f;
    var entry: u32;
    loop {
        // Level voxels (1 / 2^level from the exponent; level l has ceil(grid / 2^l) voxels),
        // clamped to the centres of the edge voxels as the sampler clamps: so the brick below
        // is within the level.
        let scale = bitcast<f32>((127 - level) << 23);
        x = clamp(x0 * scale, vec3f(0.5), ceil(NAME_layout.grid.xyz * scale) - 0.5);
        let brick = floor(x * (1.0 / edge));
        lo = brick * edge;
        let index = i32(dot(vec4f(brick, f32(level)), NAME_layout.table));
        entry = NAME_pages[index];
        // Used (least recently used bricks are evicted first), or needed.
        NAME_requests[index] = select(2u, 1u, entry == 0u);
        // Missing: the next coarser level answers (the coarsest is always resident; past it, 0).
        if entry != 0u || level >= coarsest {
            break;
        }
        level += 1;
    }
    // A resident brick's slot: 10 bits an axis; its first texel is the apron before the
    // brick's first voxel.
    let bits = bitcast<i32>(entry);
    let slot = vec3f((vec3i(bits) >> vec3u(20u, 10u, 0u)) & vec3i(1023));
    let shift = slot * (edge + 2.0 * apron) + apron - lo;
    let value = textureSampleLevel(NAME, NAME_sampler, (x + shift) * NAME_layout.pool.xyz, 0.0).x;
    // A brick of one value holds it in 30-bit fixed point.
    let constant = f32(bits & 0x3fffffff) * (1.0 / 1073741823.0);
    let kind = entry >> 30u;
    if NAME_segment_open {
        // The samples of the segment may read up to half a voxel short of the apron's end.
        let scale = bitcast<f32>((127 - level) << 23);
        let margin = apron - 0.5;
        let to_level = NAME_layout.grid.xyz * scale;
        NAME_segment_open = false;
        NAME_segment_lo = (wanted_lo * scale - margin) / to_level;
        NAME_segment_hi = ((wanted_lo + edge / wanted_scale) * scale + margin) / to_level;
        NAME_segment_to_pool = to_level * NAME_layout.pool.xyz;
        NAME_segment_pool_at = shift * NAME_layout.pool.xyz;
        NAME_segment_value = vec2f(select(0.0, constant, kind == 2u), select(1.0, 0.0, kind == 1u));
    }
    return select(select(0.0, value, kind == 1u), constant, kind == 2u);
}

// Level-0 voxels per axis of bricked volume NAME: what `dims(v)` gives.
fn NAME_dims() -> vec3u {
    return vec3u(NAME_layout.grid.xyz);
}

// Opens a segment: the next full lookup keeps the brick it finds. Until then the segment is
// empty, so that no sample reads a segment of another sample's choosing.
fn NAME_segment_start() {
    NAME_segment_open = true;
    NAME_segment_out = false;
    NAME_segment_lo = vec3f(1.0);
    NAME_segment_hi = vec3f(0.0);
}

// The value of bricked volume NAME at `p` read from the ray's segment, without the page table;
// a position outside the segment reads a wrong value and is noted (`NAME_segment_missed`).
fn NAME_sample_in_segment(p: vec3f) -> f32 {
    NAME_segment_out = NAME_segment_out || any(p < NAME_segment_lo) || any(p > NAME_segment_hi);
    let value = textureSampleLevel(NAME, NAME_sampler, p * NAME_segment_to_pool + NAME_segment_pool_at, 0.0).x;
    return select(value, NAME_segment_value.x, NAME_segment_value.y != 0.0);
}

// Whether a sample read outside the segment since the last call.
fn NAME_segment_missed() -> bool {
    let out = NAME_segment_out;
    NAME_segment_out = false;
    return out;
}
