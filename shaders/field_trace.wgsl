// Sphere tracing of a field tree on the GPU (issue 17): the GPU twin of the CPU tracer
// (thicket_core::implicit::trace). The tree comes as a flat postfix program
// (rust/render/src/field/program.rs) interpreted per pixel with a small stack of
// (value, gradient, colour, texture) results; the arithmetic of every opcode is the
// evaluator's (thicket_core::implicit::eval and kernel), in f32. Each pixel makes its
// own ray from the camera (the CPU's `Rays::ray`: near-plane origin, unit direction to
// the far plane, footprint near + grow t) and clips it to the tree's box; it steps by
// max(f / L, a tenth of the pixel's footprint) and hits where f is below that; the hit
// is shaded with the tree's colour, ambient 0.1 plus Lambert under a headlight.
//
// Program layout (f32 words): opcode, then its parameters.
//   0 PRIM   kind, center(3), axes(9), half(3), radius, color(4)   (kind 0 plane,
//            1 sphere, 2 cuboid, 3 torus)
//   1 OFFSET amount        2 NEGATE
//   3 H n    4 MIN n       5 MAX n
//   6 WP n, p, kind (0 intersection, 1 union, 2 difference)
//   7 DISPLACE amplitude, omega, tau
//   8 FRACTAL count, tau, weight, (a, omega) * count
//   9 PAINT color(4)       10 RAMP count, (position, color(4)) * count

const STACK: u32 = 16u;
const AMBIENT: f32 = 0.1;
const HIT: f32 = 0.1;

// The camera as homogeneous points (inverse(projection * view) applied to normalized
// device coordinates, in double precision on the CPU): the near and far planes'
// points at pixel coordinates (0, 0), and their change per pixel along x and y (the
// same for both planes). Pixel (x, y)'s point is near0 + x dx + y dy, then divided by w.
struct Params {
    near0: vec4<f32>,
    far0: vec4<f32>,
    dx: vec4<f32>,
    dy: vec4<f32>,
    // The tree's box, grown by the CPU tracer's margin; w is 1 where there is a box.
    lo: vec4<f32>,
    hi: vec4<f32>,
    width: u32,
    height: u32,
    length: u32,
    max_steps: u32,
    inv_lipschitz: f32,
    // Bit 0: write `geometry` too.
    flags: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> program: array<f32>;
// Per pixel: linear RGBA as four f16 (r | g << 16, b | a << 16); 0 where nothing is hit.
@group(0) @binding(2) var<storage, read_write> colors: array<vec2<u32>>;
// Per pixel, with flags bit 0: the hit's parameter t along the ray (f32 bits; -1 where
// nothing is hit) and its unit normal, octahedral, as two snorm16 (pack2x16snorm).
@group(0) @binding(3) var<storage, read_write> geometry: array<vec2<u32>>;

var<private> sf: array<f32, STACK>;
var<private> sg: array<vec3<f32>, STACK>;
var<private> sc: array<vec4<f32>, STACK>;
var<private> st: array<f32, STACK>;

fn word(i: u32) -> f32 {
    return program[i];
}

fn v3(i: u32) -> vec3<f32> {
    return vec3<f32>(program[i], program[i + 1u], program[i + 2u]);
}

fn v4(i: u32) -> vec4<f32> {
    return vec4<f32>(program[i], program[i + 1u], program[i + 2u], program[i + 3u]);
}

fn copy_slot(dst: u32, src: u32, full: bool) {
    sf[dst] = sf[src];
    if !full {
        return;
    }
    sg[dst] = sg[src];
    sc[dst] = sc[src];
    st[dst] = st[src];
}

// The n-ary h over 6 (or 4) plane values with their gradients (kernel::h).
fn h6(v: array<f32, 6>, g: array<vec3<f32>, 6>, n: u32) -> vec4<f32> {
    var top = 0u;
    for (var i = 1u; i < n; i++) {
        if v[i] > v[top] {
            top = i;
        }
    }
    let m = v[top];
    if !(m > 0.0) {
        return vec4<f32>(m, g[top]);
    }
    var ss = 0.0;
    var gg = vec3<f32>(0.0);
    for (var i = 0u; i < n; i++) {
        let w = max(v[i], 0.0) / m;
        ss += w * w;
        gg += w * g[i];
    }
    let len = sqrt(ss);
    return vec4<f32>(m * len, gg / len);
}

// A primitive's value and gradient at x (kernel::Prim::eval).
fn prim(pc: u32, x: vec3<f32>) -> vec4<f32> {
    let kind = u32(word(pc));
    let d = x - v3(pc + 1u);
    let a0 = v3(pc + 4u);
    let a1 = v3(pc + 7u);
    let a2 = v3(pc + 10u);
    let half = v3(pc + 13u);
    let radius = word(pc + 16u);
    if kind == 0u {
        return vec4<f32>(dot(a0, d), a0);
    }
    if kind == 1u {
        let l = length(d);
        var g = a0;
        if l > 0.0 {
            g = d / l;
        }
        return vec4<f32>(l - radius, g);
    }
    let f = vec3<f32>(dot(a0, d), dot(a1, d), dot(a2, d));
    if kind == 2u {
        let r = h6(array<f32, 6>(f.x - half.x, -f.x - half.x, f.y - half.y, -f.y - half.y, f.z - half.z, -f.z - half.z), array<vec3<f32>, 6>(a0, -a0, a1, -a1, a2, -a2), 6u);
        return vec4<f32>(r.x - radius, r.yzw);
    }
    let z = vec3<f32>(0.0);
    let gn = h6(array<f32, 6>(f.x, -f.x, f.y, -f.y, 0.0, 0.0), array<vec3<f32>, 6>(a0, -a0, a1, -a1, z, z), 4u);
    let n = gn.yzw;
    let r = h6(array<f32, 6>(gn.x - half.x, -gn.x + half.x, f.z, -f.z, 0.0, 0.0), array<vec3<f32>, 6>(n, -n, a2, -a2, z, z), 4u);
    return vec4<f32>(r.x - radius, r.yzw);
}

fn wp_sign(kind: u32, child: u32) -> f32 {
    if kind == 0u || (kind == 2u && child == 0u) {
        return 1.0;
    }
    return -1.0;
}

// Runs the program at x; the result is slot 0: its value, and with `full` its
// gradient, colour and texture (the march needs only values).
fn run(x: vec3<f32>, full: bool) {
    var sp = 0u;
    var pc = 0u;
    while pc < params.length {
        let op = u32(word(pc));
        pc += 1u;
        switch op {
            case 0u: {
                let r = prim(pc, x);
                sf[sp] = r.x;
                if full {
                    sg[sp] = r.yzw;
                    sc[sp] = v4(pc + 17u);
                    st[sp] = 0.0;
                }
                sp += 1u;
                pc += 21u;
            }
            case 1u: {
                sf[sp - 1u] -= word(pc);
                pc += 1u;
            }
            case 2u: {
                sf[sp - 1u] = -sf[sp - 1u];
                if full {
                    sg[sp - 1u] = -sg[sp - 1u];
                }
            }
            case 3u: {
                // h over the top k results (eval::h_block).
                let k = u32(word(pc));
                pc += 1u;
                let first = sp - k;
                var best = first;
                var m = sf[first];
                for (var i = first + 1u; i < sp; i++) {
                    if sf[i] > m {
                        m = sf[i];
                        best = i;
                    }
                }
                if m > 0.0 {
                    var ss = 0.0;
                    var sum = 0.0;
                    var g = vec3<f32>(0.0);
                    var c = vec4<f32>(0.0);
                    var t = 0.0;
                    for (var i = first; i < sp; i++) {
                        let w = max(sf[i], 0.0) / m;
                        ss += w * w;
                        if full {
                            sum += w;
                            g += w * sg[i];
                            c += w * sc[i];
                            t += w * st[i];
                        }
                    }
                    let len = sqrt(ss);
                    sf[first] = m * len;
                    if full {
                        sg[first] = g / len;
                        sc[first] = c / sum;
                        st[first] = t / sum;
                    }
                } else if best != first {
                    copy_slot(first, best, full);
                }
                sp = first + 1u;
            }
            case 4u, 5u: {
                let k = u32(word(pc));
                pc += 1u;
                let first = sp - k;
                var best = first;
                for (var i = first + 1u; i < sp; i++) {
                    if (op == 4u && sf[i] < sf[best]) || (op == 5u && sf[i] > sf[best]) {
                        best = i;
                    }
                }
                if best != first {
                    copy_slot(first, best, full);
                }
                sp = first + 1u;
            }
            case 6u: {
                // outer * w_p(sign_i f_i) by log-sum-exp (eval::wp_block).
                let k = u32(word(pc));
                let p = word(pc + 1u);
                let kind = u32(word(pc + 2u));
                pc += 3u;
                let first = sp - k;
                var top = -3.4e38;
                for (var i = first; i < sp; i++) {
                    top = max(top, p * wp_sign(kind, i - first) * sf[i]);
                }
                var outer = 1.0;
                if kind == 1u {
                    outer = -1.0;
                }
                var sum = 0.0;
                var g = vec3<f32>(0.0);
                var c = vec4<f32>(0.0);
                var t = 0.0;
                for (var i = first; i < sp; i++) {
                    let s = wp_sign(kind, i - first);
                    let e = exp(p * s * sf[i] - top);
                    sum += e;
                    if full {
                        g += e * s * outer * sg[i];
                        c += e * sc[i];
                        t += e * st[i];
                    }
                }
                sf[first] = outer * (top + log(sum)) / p;
                if full {
                    sg[first] = g / sum;
                    sc[first] = c / sum;
                    st[first] = t / sum;
                }
                sp = first + 1u;
            }
            case 7u: {
                let amplitude = word(pc);
                let omega = word(pc + 1u);
                let tau = word(pc + 2u);
                pc += 3u;
                sp -= 1u;
                let s = sp - 1u;
                let phase = omega * sf[sp] + tau;
                sf[s] += amplitude * (cos(phase) + 1.0);
                if full {
                    sg[s] += -amplitude * omega * sin(phase) * sg[sp];
                    st[s] = 0.5 * (1.0 + cos(phase));
                }
            }
            case 8u: {
                let count = u32(word(pc));
                let tau = word(pc + 1u);
                let weight = word(pc + 2u);
                pc += 3u;
                sp -= 1u;
                let s = sp - 1u;
                let f = sf[sp];
                var add = 0.0;
                var d = 0.0;
                var t = 0.0;
                for (var j = 0u; j < count; j++) {
                    let a = word(pc + 2u * j);
                    let omega = word(pc + 2u * j + 1u);
                    let phase = omega * f + tau;
                    add += a * (cos(phase) + 1.0);
                    d -= a * omega * sin(phase);
                    t += abs(a) * 0.5 * (1.0 + cos(phase));
                }
                sf[s] += add;
                if !full {
                    pc += 2u * count;
                    continue;
                }
                sg[s] += d * sg[sp];
                if weight > 0.0 {
                    st[s] = t / weight;
                } else {
                    st[s] = 0.5 * (1.0 + cos(word(pc + 1u) * f + tau));
                }
                pc += 2u * count;
            }
            case 9u: {
                if full {
                    sc[sp - 1u] = v4(pc);
                }
                pc += 4u;
            }
            case 10u: {
                // tree::ramp_color at the texture value.
                let count = u32(word(pc));
                pc += 1u;
                if !full {
                    pc += 5u * count;
                    continue;
                }
                let t = st[sp - 1u];
                var c = v4(pc + 1u);
                if t > word(pc) {
                    var i = 0u;
                    while i < count && word(pc + 5u * i) <= t {
                        i++;
                    }
                    if i == count {
                        c = v4(pc + 5u * (count - 1u) + 1u);
                    } else {
                        let p0 = word(pc + 5u * (i - 1u));
                        let p1 = word(pc + 5u * i);
                        let w = (t - p0) / (p1 - p0);
                        c = mix(v4(pc + 5u * (i - 1u) + 1u), v4(pc + 5u * i + 1u), w);
                    }
                }
                sc[sp - 1u] = c;
                pc += 5u * count;
            }
            default: {
                return;
            }
        }
    }
}

fn finite4(v: vec4<f32>) -> vec4<f32> {
    var out = v;
    for (var i = 0u; i < 4u; i++) {
        let x = v[i];
        if !(abs(x) <= 3.4e38) {
            out[i] = 0.0;
        }
    }
    return out;
}

// The IEEE binary16 bits of a finite x within f16's range, rounded to nearest even
// (pack2x16float needs a capability naga does not grant by default).
fn f16_bits(x: f32) -> u32 {
    let b = bitcast<u32>(x);
    let sign = (b >> 16u) & 0x8000u;
    let a = b & 0x7fffffffu;
    if a >= 0x47800000u {
        return sign | 0x7c00u;
    }
    if a < 0x38800000u {
        // Subnormal (or zero): units of 2^-24; round() is to nearest even.
        return sign | u32(round(bitcast<f32>(a) * 16777216.0));
    }
    // Rebias the exponent (127 to 15) and round the 13 dropped bits to nearest even.
    let r = a - 0x38000000u;
    return sign | ((r + 0xfffu + ((r >> 13u) & 1u)) >> 13u);
}

fn pack_half2(v: vec2<f32>) -> u32 {
    return f16_bits(v.x) | (f16_bits(v.y) << 16u);
}

// A unit vector's octahedral coordinates in [-1, 1]^2.
fn octahedral(n: vec3<f32>) -> vec2<f32> {
    let p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    if n.z >= 0.0 {
        return p;
    }
    return (1.0 - abs(p.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
}

// One pixel's ray (the CPU's `Rays::ray` at the pixel's centre).
struct PixelRay {
    ok: bool,
    origin: vec3<f32>,
    dir: vec3<f32>,
    length: f32,
    near: f32,
    grow: f32,
}

// The world point of a homogeneous one, and the change of that point when the
// homogeneous point moves by `d` (one pixel along x), without cancellation when d.w = 0.
fn pixel_step(h: vec4<f32>, d: vec4<f32>) -> f32 {
    return length(d.xyz * h.w - h.xyz * d.w) / abs(h.w * (h.w + d.w));
}

fn make_ray(px: f32, py: f32) -> PixelRay {
    var r: PixelRay;
    r.ok = false;
    let hn = params.near0 + px * params.dx + py * params.dy;
    let hf = params.far0 + px * params.dx + py * params.dy;
    if hn.w == 0.0 || hf.w == 0.0 {
        return r;
    }
    r.origin = hn.xyz / hn.w;
    let d = hf.xyz / hf.w - r.origin;
    r.length = length(d);
    r.near = pixel_step(hn, params.dx);
    let far = pixel_step(hf, params.dx);
    if !(r.length > 0.0 && r.length <= 3.4e38 && r.near <= 3.4e38 && far <= 3.4e38 && all(abs(r.origin) <= vec3<f32>(3.4e38))) {
        return r;
    }
    r.dir = d / r.length;
    r.grow = (far - r.near) / r.length;
    r.ok = true;
    return r;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let index = id.y * params.width + id.x;
    let ray = make_ray(f32(id.x) + 0.5, f32(id.y) + 0.5);
    let origin = ray.origin;
    let dir = ray.dir;
    // The part [t, end] of [0, length] inside the box (the CPU's clip; a direction
    // along a slab keeps the range where the origin is inside it).
    var t = 0.0;
    var end = ray.length;
    var live = ray.ok;
    if live && params.lo.w > 0.0 {
        for (var a = 0u; a < 3u; a++) {
            if dir[a] == 0.0 {
                if origin[a] < params.lo[a] || origin[a] > params.hi[a] {
                    live = false;
                }
                continue;
            }
            let inv = 1.0 / dir[a];
            var u = (params.lo[a] - origin[a]) * inv;
            var v = (params.hi[a] - origin[a]) * inv;
            if u > v {
                let s = u;
                u = v;
                v = s;
            }
            if u > t {
                t = u;
            }
            if v < end {
                end = v;
            }
        }
    }
    var rgba = vec4<f32>(0.0);
    var depth = -1.0;
    var normal = vec3<f32>(0.0, 0.0, 1.0);
    var hit = false;
    var x = origin;
    if live && t <= end {
        for (var step = 0u; step < params.max_steps; step++) {
            x = origin + t * dir;
            run(x, false);
            let f = sf[0];
            let eps = HIT * max(ray.near + ray.grow * t, 1e-12);
            if f < eps {
                hit = true;
                break;
            }
            t += max(f * params.inv_lipschitz, eps);
            if !(t <= end) {
                break;
            }
        }
    }
    if hit {
        run(x, true);
        let g = sg[0];
        normal = -dir;
        let l = length(g);
        if l > 0.0 && l <= 3.4e38 {
            normal = g / l;
        }
        let light = AMBIENT + (1.0 - AMBIENT) * abs(dot(normal, dir));
        // Finite, and within f16's range.
        rgba = clamp(finite4(vec4<f32>(sc[0].rgb * light, clamp(sc[0].a, 0.0, 1.0))), vec4<f32>(-65504.0), vec4<f32>(65504.0));
        depth = t;
    }
    colors[index] = vec2<u32>(pack_half2(rgba.xy), pack_half2(rgba.zw));
    if (params.flags & 1u) != 0u {
        geometry[index] = vec2<u32>(bitcast<u32>(depth), pack2x16snorm(octahedral(normal)));
    }
}
