// A raycaster written by hand, doing the same work as the composed shader of
// examples/basic/scene.toml's "3d" view without empty-space skipping (camera ray, steps of
// `step_size` mm through `volume_to_world`, jitter, trilinear sample, transfer function; for
// visible samples only: central-difference gradient taken to patient space by
// `gradient_to_world`, one Blinn-Phong light aimed in patient space, opacity correction
// for the physical step, front-to-back DVR, the transparent ones gathered in an inner loop as the
// composer's entry point does; early termination, background). Same bindings and
// uniform block, so the runtime drives both alike. Used only by benches/render.rs as the
// baseline.

struct Uniforms {
    inv_view_proj: mat4x4<f32>,
    volume_to_world: mat4x4<f32>,
    step_size: f32,
    jitter: f32,
    light_dir_key: vec3<f32>,
    gradient_to_world: mat3x3<f32>,
    light_color_key: vec3<f32>,
    diffuse: f32,
    specular: f32,
    shininess: f32,
    ambient: f32,
    ref_step: f32,
    ert_threshold: f32,
    background: vec4<f32>,
    max_samples: u32,
}

@group(0) @binding(0) var<uniform> u: Uniforms;
@group(0) @binding(1) var output: texture_storage_2d<rgba8unorm, write>;
@group(0) @binding(2) var<uniform> region: vec4<u32>;
@group(0) @binding(3) var volume: texture_3d<f32>;
@group(0) @binding(4) var volume_sampler: sampler;
@group(0) @binding(5) var tf: texture_2d<f32>;
@group(0) @binding(6) var tf_sampler: sampler;

fn unproject(p: vec3<f32>) -> vec3<f32> {
    let h = u.inv_view_proj * vec4<f32>(p, 1.0);
    return h.xyz / h.w;
}

fn hash2(p: vec2<f32>) -> f32 {
    var h = (u32(p.x * 65536.0) * 73856093u) ^ (u32(p.y * 65536.0) * 19349663u);
    h = (h ^ (h >> 16u)) * 0x45d9f3bu;
    h = (h ^ (h >> 16u)) * 0x45d9f3bu;
    h = h ^ (h >> 16u);
    return f32(h & 0xffffffu) / 16777216.0;
}

fn value_at(p: vec3<f32>) -> f32 {
    return textureSampleLevel(volume, volume_sampler, p, 0.0).x;
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(output);
    let p = id.xy + region.xy;
    if p.x >= min(region.z, size.x) || p.y >= min(region.w, size.y) {
        return;
    }
    let pixel = (vec2<f32>(p) + 0.5) / vec2<f32>(size);
    let ndc = vec2<f32>(pixel.x * 2.0 - 1.0, 1.0 - pixel.y * 2.0);
    let origin = unproject(vec3<f32>(ndc, 0.0));
    let dir = normalize(unproject(vec3<f32>(ndc, 1.0)) - origin);
    let inv = 1.0 / select(dir, vec3<f32>(1e-8), abs(dir) < vec3<f32>(1e-8));
    let t0 = -origin * inv;
    let t1 = (1.0 - origin) * inv;
    let t_lo = min(t0, t1);
    let t_hi = max(t0, t1);
    let dt = u.step_size / max(length((u.volume_to_world * vec4<f32>(dir, 0.0)).xyz), 1e-6);
    var t = max(max(t_lo.x, t_lo.y), max(t_lo.z, 0.0)) + u.jitter * hash2(pixel) * dt;
    let t_exit = min(min(t_hi.x, t_hi.y), t_hi.z);
    let h = 1.0 / vec3<f32>(textureDimensions(volume));
    // Lighting happens in patient space: the view direction once per ray, the normal per sample.
    let view = -normalize((u.volume_to_world * vec4<f32>(dir, 0.0)).xyz);
    let light = select(view, normalize(u.light_dir_key), dot(u.light_dir_key, u.light_dir_key) > 0.0);
    var accum = vec4<f32>(0.0);
    var i = 0u;
    loop {
        if i >= u.max_samples || t > t_exit {
            break;
        }
        // Transparent samples in an inner loop, so that lanes running in lockstep shade their
        // visible samples together (lavapipe runs an `if` body for all lanes if one takes it).
        var pos = origin + t * dir;
        var color = textureSampleLevel(tf, tf_sampler, vec2<f32>(value_at(pos), 0.5), 0.0);
        loop {
            if color.a > 0.0 {
                break;
            }
            t += dt;
            i++;
            if i >= u.max_samples || t > t_exit {
                break;
            }
            pos = origin + t * dir;
            color = textureSampleLevel(tf, tf_sampler, vec2<f32>(value_at(pos), 0.5), 0.0);
        }
        if !(color.a > 0.0) {
            break;
        }
        let g = vec3<f32>(
            value_at(pos + vec3<f32>(h.x, 0.0, 0.0)) - value_at(pos - vec3<f32>(h.x, 0.0, 0.0)),
            value_at(pos + vec3<f32>(0.0, h.y, 0.0)) - value_at(pos - vec3<f32>(0.0, h.y, 0.0)),
            value_at(pos + vec3<f32>(0.0, 0.0, h.z)) - value_at(pos - vec3<f32>(0.0, 0.0, h.z))) / (2.0 * h);
        var lit = u.diffuse * u.light_color_key;
        var specular = vec3<f32>(0.0);
        let g_world = u.gradient_to_world * g;
        let len = length(g_world);
        if len >= 1e-6 {
            var n = -g_world / len;
            n = select(n, -n, dot(n, view) < 0.0);
            let d = max(dot(n, light), 0.0);
            var s = 0.0;
            if d > 0.0 {
                s = pow(max(dot(n, normalize(light + view)), 0.0), u.shininess);
            }
            lit = u.diffuse * d * u.light_color_key;
            specular = u.specular * s * u.light_color_key;
        }
        let rgb = color.rgb * (u.ambient + lit) + specular;
        let a = 1.0 - pow(max(1.0 - clamp(color.a, 0.0, 1.0), 1e-6), u.step_size / u.ref_step);
        accum += (1.0 - accum.a) * vec4<f32>(rgb * a, a);
        if accum.a > u.ert_threshold {
            break;
        }
        t += dt;
        i++;
    }
    textureStore(output, p, accum + (1.0 - accum.a) * u.background);
}
