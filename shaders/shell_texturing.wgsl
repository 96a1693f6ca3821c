// Shell texturing: the technique games and Blender users use today for fur and grass,
// drawn as the peer of Thicket's slice renderer (rust/render/src/gpu/shell_texturing.rs).
//
// N copies ("shells") of the base mesh, copy k offset along the vertex normals by
// (k + 1/2) / N of the per-vertex thickness, one instance per copy. Every fragment of
// copy k samples the volume texture at (s, t, r_k), r_k = (k + 1/2) / N, with the
// (s, t) of its base corner (the same tiling as the slice renderer's cells), and is
// discarded below the iso-level alpha = 0.5 (the alpha test); depth-tested, opaque,
// Lambert-shaded with the interpolated vertex normal.

struct Globals {
    // World to clip space, depth reversed (1 on the near plane, 0 on the far one).
    view_proj: mat4x4<f32>,
    // Depth along the view axis: -(dot(view_z.xyz, x) + view_z.w).
    view_z: vec4<f32>,
    // The camera: its position (w = 1, perspective) or view direction (w = 0).
    eye: vec4<f32>,
    // Unit direction toward the light, world space; w: ambient share.
    light: vec4<f32>,
    // Linear albedo.
    albedo: vec4<f32>,
    // Per texture layer: its tile offset (s, t); z: its texel rows nz across the shell.
    layers: array<vec4<f32>, 4>,
    // x: texture layers (1 to 4), united (max alpha); y: the number of shells N.
    counts: vec4<u32>,
};

@group(0) @binding(0) var<uniform> globals: Globals;
@group(0) @binding(1) var volume_sampler: sampler;
// The layers' alpha. Repeat in s, t, clamp in r. Slots past the layer count hold layer 0.
@group(0) @binding(2) var volume_0: texture_3d<f32>;
@group(0) @binding(3) var volume_1: texture_3d<f32>;
@group(0) @binding(4) var volume_2: texture_3d<f32>;
@group(0) @binding(5) var volume_3: texture_3d<f32>;

struct Corner {
    // Base point; w: s.
    @location(0) base: vec4<f32>,
    // Normal times thickness; w: t.
    @location(1) offset: vec4<f32>,
    // Unit vertex normal.
    @location(2) normal: vec4<f32>,
};

struct Varying {
    @builtin(position) position: vec4<f32>,
    @location(0) tex: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) world: vec3<f32>,
    @location(3) view_depth: f32,
};

@vertex
fn vs_shell(corner: Corner, @builtin(instance_index) k: u32) -> Varying {
    let r = (f32(k) + 0.5) / f32(globals.counts.y);
    let x = corner.base.xyz + r * corner.offset.xyz;
    var out: Varying;
    out.position = globals.view_proj * vec4<f32>(x, 1.0);
    out.tex = vec3<f32>(corner.base.w, corner.offset.w, r);
    out.normal = corner.normal.xyz;
    out.world = x;
    out.view_depth = -(dot(globals.view_z.xyz, x) + globals.view_z.w);
    return out;
}

// Layer k's alpha at texture coordinates (s, t, r): texel centres at (i + 1/2) / n in
// s, t and k / (nz - 1) in r, as on the CPU; finest level.
fn layer_alpha(k: u32, tex: vec3<f32>) -> f32 {
    let info = globals.layers[k];
    let p = vec3<f32>(tex.xy + info.xy, (clamp(tex.z, 0.0, 1.0) * (info.z - 1.0) + 0.5) / info.z);
    switch k {
        case 1u: { return textureSampleLevel(volume_1, volume_sampler, p, 0.0).r; }
        case 2u: { return textureSampleLevel(volume_2, volume_sampler, p, 0.0).r; }
        case 3u: { return textureSampleLevel(volume_3, volume_sampler, p, 0.0).r; }
        default: { return textureSampleLevel(volume_0, volume_sampler, p, 0.0).r; }
    }
}

struct Output {
    // Shaded colour, alpha 1.
    @location(0) color: vec4<f32>,
    // Unit normal facing the camera; w: depth along the view axis.
    @location(1) normal_depth: vec4<f32>,
};

@fragment
fn fs_shell(v: Varying) -> Output {
    var alpha = layer_alpha(0u, v.tex);
    let count = min(globals.counts.x, 4u);
    for (var k = 1u; k < count; k++) {
        alpha = max(alpha, layer_alpha(k, v.tex));
    }
    if alpha < 0.5 {
        discard;
    }
    // Vertices without a normal have no offset either; any unit vector will do.
    let len = length(v.normal);
    var n = select(vec3<f32>(0.0, 0.0, 1.0), v.normal / len, len > 1e-12);
    let ray = select(globals.eye.xyz, v.world - globals.eye.xyz, globals.eye.w > 0.5);
    if dot(n, ray) > 0.0 {
        n = -n;
    }
    let shade = globals.light.w + (1.0 - globals.light.w) * max(dot(n, globals.light.xyz), 0.0);
    return Output(vec4<f32>(globals.albedo.xyz * shade, 1.0), vec4<f32>(n, v.view_depth));
}
