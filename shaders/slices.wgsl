// Thicket's slice renderer for volume-textured shells (Peng & Zorin 2004, thick
// surfaces, chapter 5), in three passes over the same slice geometry:
//
//   1. `vs_slice` + `fs_inside`: every slice fragment samples alpha at its texture
//      coordinates and is kept where alpha >= 0.5 (the alpha test); the depth test
//      keeps the nearest. Output T1: the fragment's cell parameters (u, v, r), its
//      cell and face code; and Z1: its depth along the view axis (full precision).
//   2. `vs_slice` + `fs_outside` (interpolating mode only): the fragments with
//      alpha < 0.5 of the same cell as T1 and in front of Z1; the reversed depth test
//      keeps the farthest, i.e. the last outside slice before the surface. Output T2.
//   3. `vs_fullscreen` + `fs_shade`: interpolates T1 and T2 by their alphas (the
//      linear root of alpha = 0.5), looks up the gradient there, carries it to world
//      space through the interpolated per-corner transform and lights it.
//
// The slice geometry is a template in cell parameters (u, v, r) (barycentric
// (1-u-v, u, v) on the base triangle, r along the directors), instanced per cell
// and mapped through the cell in `vs_slice` (see rust/render/src/gpu/slices.rs):
// layers r = const or sections across the prism, whichever the view ray crosses
// most often, plus the prism's faces, all drawn a little inside the cell so that the
// two copies of a face shared by two cells are met in order. Texture coordinates
// (s, t, r) are affine in (u, v, r) within a cell, so interpolating one interpolates
// the other; T1 and T2 hold (u, v, r) and the tag of their cell, and pass 2 keeps
// T1's cell only, so both ends of an interpolation come from the same texture.
//
// The texture is the union of up to four layers, each shifted by its (s, t) offset:
// alpha is the largest of theirs, the gradient that of the layer it comes from
// (`sample_union`), wherever the shaders sample it.
//
// Distant views (chapter 6): every sample reads the mip level whose texels match the
// pixel's footprint (`cell_lod`). With double mipmaps the layers' chains are empty
// below the transition level, so the alpha test clips the far surface there, and
//   4. `vs_slice` + `fs_haze` draws the transparency chain of the united layers over
//      it: layers r = const of every cell, from the base outward, alpha-blended
//      (directional alpha, normal-distribution ellipsoids shaded with nine samples),
//      behind nothing nearer than Z1; `fs_shade` composites it over the surface.

struct Globals {
    // World to clip space, depth reversed (1 on the near plane, 0 on the far one).
    view_proj: mat4x4<f32>,
    // Clip space to world, for the pixel rays of the final pass.
    inv_view_proj: mat4x4<f32>,
    // Depth along the view axis: -(dot(view_z.xyz, x) + view_z.w).
    view_z: vec4<f32>,
    // Unit direction toward the light, world space; w: ambient share.
    light: vec4<f32>,
    // Linear albedo; w: 1 for the interpolating mode, 0 for plain slicing.
    albedo: vec4<f32>,
    // Per texture layer: its tile offset (s, t); z: its texel rows nz across the
    // shell; w: sqrt(nx ny), its texels per tile side. Layers from `layer_count.x` on
    // are unused.
    layers: array<vec4<f32>, 4>,
    // x: the number of texture layers (1 to 4), united (max alpha).
    layer_count: vec4<u32>,
    // Viewport width, height and their reciprocals.
    viewport: vec4<f32>,
    // x: world size of a pixel at unit depth (perspective) or everywhere
    // (orthographic); y: 1 for perspective; z: mipmaps (0 off, 1 linear, 2 double);
    // w: the number of transparency layers.
    mip: vec4<f32>,
    // The transparency chain's finest size (nx, ny, nz); w: the transition level.
    haze: vec4<f32>,
    // x: 1 where the cells' region and hole weights apply (`effects`); y: the base
    // slab's top in r; z: the layers across the shell (the slab's edge is one wide).
    effects: vec4<f32>,
    // The moved region (chapter 7.2): its mask's first texel (s, t), 1 / texel size,
    // and w = 1 where there is one; then how far it moved in (s, t).
    moved: vec4<f32>,
    moved_offset: vec4<f32>,
    // The cutter (chapter 7.3): its bins' first (x, y), bin size, w = 1 where there
    // is one; x of the next: bins per side.
    cutter: vec4<f32>,
    cutter_bins: vec4<u32>,
};

// A triangle prism: base corners with their s in w, directors with their t in w.
struct Cell {
    corner: array<vec4<f32>, 3>,
    director: array<vec4<f32>, 3>,
};

// Per cell, J_world^{-T} (parameter gradient to world gradient) at the six corners:
// index 2k is corner k on the base (r = 0), 2k+1 on the outer layer (r = 1).
struct CellFrames {
    corner: array<mat3x3<f32>, 6>,
};

@group(0) @binding(0) var<uniform> globals: Globals;
@group(0) @binding(1) var<storage, read> cells: array<Cell>;
@group(0) @binding(2) var<storage, read> frames: array<CellFrames>;
// The texture layers, rgb: d alpha / d(s, t, r) at texel centres; a: alpha. Repeat
// in s, t, clamp in r. Slots past the layer count hold layer 0 again (never sampled).
@group(0) @binding(3) var volume_texture_0: texture_3d<f32>;
@group(0) @binding(4) var volume_sampler: sampler;
@group(0) @binding(6) var volume_texture_1: texture_3d<f32>;
@group(0) @binding(7) var volume_texture_2: texture_3d<f32>;
@group(0) @binding(8) var volume_texture_3: texture_3d<f32>;
// The transparency chain (double mipmaps): directional alpha along (s, t, r) and the
// column's alpha across the shell (w), and the ellipsoid Q^-1 as its diagonal and its
// off-diagonal (01, 02, 12) entries.
@group(0) @binding(9) var haze_alpha: texture_3d<f32>;
@group(0) @binding(10) var haze_ndf_diagonal: texture_3d<f32>;
@group(0) @binding(11) var haze_ndf_off_diagonal: texture_3d<f32>;

// Per cell and side face (u = 0, v = 0, w = 0), the (s, t) the neighbouring cell has
// at the face's two corners: (s_a, t_a, s_b, t_b); s_a = NO_NEIGHBOUR on the shell's
// boundary.
struct Neighbours {
    face: array<vec4<f32>, 3>,
};
const NO_NEIGHBOUR: f32 = 3.0e38;

@group(0) @binding(5) var<storage, read> neighbours: array<Neighbours>;

// The stack's per-vertex effects at a cell's corners (thick surfaces, figure 3.3 and
// chapter 7.3), as `texture::bake::Effects` applies them on the CPU: where the
// texture is (region; elsewhere a base slab) and what holes cut away.
struct CellEffects {
    region: vec4<f32>,
    holes: vec4<f32>,
};
@group(0) @binding(12) var<storage, read> effects: array<CellEffects>;
// Where the moved region came from, a mask in (s, t), read texel by texel and
// interpolated as on the CPU. The cutter's triangles (three corners each) and its
// bins over the xy plane (side² + 1 offsets into the triangle indices after them).
@group(0) @binding(13) var moved_mask: texture_2d<f32>;
@group(0) @binding(14) var<storage, read> cutter_triangles: array<vec4<f32>>;
@group(0) @binding(15) var<storage, read> cutter_bins: array<u32>;

// T1: bitcast (u, v, r) of the nearest inside fragment, w = (cell + 1) * 8 + face
// (0: empty pixel). Z1: its depth along the view axis.
@group(1) @binding(0) var first_hit: texture_2d<u32>;
@group(1) @binding(1) var first_depth: texture_2d<f32>;
// T2: (u, v, r) of the last outside fragment before T1 in T1's cell, w = its depth
// (0: none).
@group(2) @binding(0) var second_hit: texture_2d<f32>;
// The transparency pass's result, premultiplied colour and alpha.
@group(2) @binding(1) var haze_image: texture_2d<f32>;

// Face codes of the template (0: an interior slice).
const FACE_U0: u32 = 1u; // u = 0 (edge from corner 2 to corner 0)
const FACE_V0: u32 = 2u; // v = 0 (edge from corner 0 to corner 1)
const FACE_W0: u32 = 3u; // 1 - u - v = 0 (edge from corner 1 to corner 2)
const FACE_BASE: u32 = 4u; // r = 0
const FACE_TOP: u32 = 5u; // r = 1

fn barycentric(q: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(1.0 - q.x - q.y, q.x, q.y);
}

fn cell_world(c: Cell, q: vec3<f32>) -> vec3<f32> {
    let w = barycentric(q);
    return w.x * (c.corner[0].xyz + q.z * c.director[0].xyz)
        + w.y * (c.corner[1].xyz + q.z * c.director[1].xyz)
        + w.z * (c.corner[2].xyz + q.z * c.director[2].xyz);
}

// Texture coordinates (s, t, r) at cell parameters q.
fn cell_texture(c: Cell, q: vec3<f32>) -> vec3<f32> {
    let w = barycentric(q);
    let s = w.x * c.corner[0].w + w.y * c.corner[1].w + w.z * c.corner[2].w;
    let t = w.x * c.director[0].w + w.y * c.director[1].w + w.z * c.director[2].w;
    return vec3<f32>(s, t, q.z);
}

// The (s, t, w) a 3D texture of nz rows across the shell is sampled at for texture
// coordinates (s, t, r): texel centres lie at (i + 1/2) / n in s and t and at
// k / (nz - 1) in r, as on the CPU.
fn volume_coords(tex: vec3<f32>, nz: f32) -> vec3<f32> {
    return vec3<f32>(tex.xy, (clamp(tex.z, 0.0, 1.0) * (nz - 1.0) + 0.5) / nz);
}

// log2 of the tiles a pixel spans at view depth `depth` in cell `c` (chapter 6); a
// texture of n texels per tile side is read at level lod + log2(n). Very low with
// mipmaps off (level 0 everywhere).
fn cell_lod(c: Cell, depth: f32) -> f32 {
    if globals.mip.z < 0.5 {
        return -64.0;
    }
    let m0 = c.corner[0].xyz + 0.5 * c.director[0].xyz;
    let m1 = c.corner[1].xyz + 0.5 * c.director[1].xyz;
    let m2 = c.corner[2].xyz + 0.5 * c.director[2].xyz;
    let world = length(cross(m1 - m0, m2 - m0));
    let ds = vec2<f32>(c.corner[1].w - c.corner[0].w, c.corner[2].w - c.corner[0].w);
    let dt = vec2<f32>(c.director[1].w - c.director[0].w, c.director[2].w - c.director[0].w);
    let tiles = abs(ds.x * dt.y - ds.y * dt.x);
    let pixel = globals.mip.x * select(1.0, max(depth, 0.0), globals.mip.y > 0.5);
    return log2(max(pixel * sqrt(tiles / max(world, 1e-30)), 1e-30));
}

// Texture layer k (gradient, alpha) at texture coordinates (s, t, r) shifted by the
// layer's offset, at the level for `lod` (see `cell_lod`).
fn sample_layer(k: u32, tex: vec3<f32>, lod: f32) -> vec4<f32> {
    let info = globals.layers[k];
    let p = volume_coords(vec3<f32>(tex.xy + info.xy, tex.z), info.z);
    let level = max(lod + log2(info.w), 0.0);
    switch k {
        case 1u: { return textureSampleLevel(volume_texture_1, volume_sampler, p, level); }
        case 2u: { return textureSampleLevel(volume_texture_2, volume_sampler, p, level); }
        case 3u: { return textureSampleLevel(volume_texture_3, volume_sampler, p, level); }
        default: { return textureSampleLevel(volume_texture_0, volume_sampler, p, level); }
    }
}

// The union of the texture layers at texture coordinates (s, t, r): the largest alpha
// with the gradient of the layer it comes from (the first of equals), as
// `ShellScene::alpha` and `ShellScene::gradient` on the CPU.
fn sample_union(tex: vec3<f32>, lod: f32) -> vec4<f32> {
    var best = sample_layer(0u, tex, lod);
    let count = min(globals.layer_count.x, 4u);
    for (var k = 1u; k < count; k++) {
        let v = sample_layer(k, tex, lod);
        if v.a > best.a {
            best = v;
        }
    }
    return best;
}

// A corner weight at barycentric w: the corners' value where they agree (exact, as
// on the CPU), else interpolated.
fn corner_weight(corners: vec3<f32>, w: vec3<f32>) -> f32 {
    if corners.x == corners.y && corners.y == corners.z {
        return corners.x;
    }
    return clamp(dot(corners, w), 0.0, 1.0);
}

// The moved region's mask at (s, t): bilinear between its texels, 0 outside it
// (`UvMask::sample` on the CPU).
fn moved_weight(st: vec2<f32>) -> f32 {
    let size = vec2<f32>(textureDimensions(moved_mask));
    let g = (st - globals.moved.xy) * globals.moved.z;
    if !(g.x >= 0.0 && g.y >= 0.0) || g.x >= size.x - 1.0 || g.y >= size.y - 1.0 {
        return 0.0;
    }
    let i = vec2<i32>(floor(g));
    let f = g - floor(g);
    let top = mix(textureLoad(moved_mask, i, 0).x, textureLoad(moved_mask, i + vec2<i32>(1, 0), 0).x, f.x);
    let bottom = mix(textureLoad(moved_mask, i + vec2<i32>(0, 1), 0).x, textureLoad(moved_mask, i + vec2<i32>(1, 1), 0).x, f.x);
    return mix(top, bottom, f.y);
}

fn cross2(u: vec2<f32>, v: vec2<f32>) -> f32 {
    return u.x * v.y - u.y * v.x;
}

// Whether q lies on the inner side of edge u-v of a counter-clockwise triangle, a
// point on the edge counting for one triangle of the two that share it (top-left).
fn inner_side(u: vec2<f32>, v: vec2<f32>, q: vec2<f32>) -> bool {
    let d = v - u;
    let e = cross2(d, q - u);
    return e > 0.0 || (e == 0.0 && (d.y < 0.0 || (d.y == 0.0 && d.x < 0.0)));
}

// Whether world point x lies inside the cutter: an odd number of its triangles
// crossed by the vertical line above x, among those of x's bin (`Cutter::contains`
// on the CPU, the same bins and rule).
fn inside_cutter(x: vec3<f32>) -> bool {
    let side = globals.cutter_bins.x;
    let g = floor((x.xy - globals.cutter.xy) / globals.cutter.z);
    if g.x < 0.0 || g.y < 0.0 || g.x > f32(side) || g.y > f32(side) {
        return false;
    }
    let bin = min(u32(g.y), side - 1u) * side + min(u32(g.x), side - 1u);
    var above = 0u;
    for (var k = cutter_bins[bin]; k < cutter_bins[bin + 1u]; k++) {
        let t = cutter_bins[k] * 3u;
        let a = cutter_triangles[t].xyz;
        var b = cutter_triangles[t + 1u].xyz;
        var c = cutter_triangles[t + 2u].xyz;
        let area = cross2(b.xy - a.xy, c.xy - a.xy);
        if area == 0.0 {
            continue;
        }
        if area < 0.0 {
            let swap = b;
            b = c;
            c = swap;
        }
        let q = x.xy;
        if !(inner_side(a.xy, b.xy, q) && inner_side(b.xy, c.xy, q) && inner_side(c.xy, a.xy, q)) {
            continue;
        }
        let w = vec3<f32>(cross2(c.xy - b.xy, q - b.xy), cross2(a.xy - c.xy, q - c.xy), cross2(b.xy - a.xy, q - a.xy));
        if (a.z * w.x + b.z * w.y + c.z * w.z) / (w.x + w.y + w.z) > x.z {
            above++;
        }
    }
    return (above & 1u) == 1u;
}

// The stack's effects on the texture's (gradient, alpha) `v`, sampled at texture
// coordinates `tex`, at parameters q of `cell` (world point x), as
// `texture::bake::Effects` on the CPU: alpha = kept * (arrived * there + (1 -
// arrived) * (presence * here + (1 - presence) * base slab)), where `there` is the
// texture where a moved piece came from; the gradient (texture space) blended
// alike, the weights' own variation left out.
fn with_effects(cell: u32, q: vec3<f32>, tex: vec3<f32>, x: vec3<f32>, lod: f32, v: vec4<f32>) -> vec4<f32> {
    if globals.effects.x < 0.5 {
        return v;
    }
    if globals.cutter.w > 0.5 && inside_cutter(x) {
        return vec4<f32>(0.0);
    }
    let e = effects[cell];
    let w = barycentric(q);
    var presence = corner_weight(e.region.xyz, w);
    var arrived = 0.0;
    var there = vec4<f32>(0.0);
    if globals.moved.w > 0.5 {
        presence *= 1.0 - moved_weight(tex.xy);
        let origin = tex.xy - globals.moved_offset.xy;
        arrived = moved_weight(origin);
        if arrived > 0.0 {
            there = sample_union(vec3<f32>(origin, tex.z), lod);
        }
    }
    let kept = 1.0 - corner_weight(e.holes.xyz, w);
    let raw = (globals.effects.y - q.z) * globals.effects.z + 0.5;
    let base = clamp(raw, 0.0, 1.0);
    let base_slope = select(0.0, -globals.effects.z, raw > 0.0 && raw < 1.0);
    let here = presence * v + (1.0 - presence) * vec4<f32>(0.0, 0.0, base_slope, base);
    return kept * (arrived * there + (1.0 - arrived) * here);
}

// The share of the texture the effects let show at q of `cell` (world point x,
// texture point st): what the region, a moved piece and the holes let through; the
// transparency pass draws far textures only, not the base slab.
fn texture_share(cell: u32, q: vec3<f32>, st: vec2<f32>, x: vec3<f32>) -> f32 {
    if globals.effects.x < 0.5 {
        return 1.0;
    }
    if globals.cutter.w > 0.5 && inside_cutter(x) {
        return 0.0;
    }
    let e = effects[cell];
    let w = barycentric(q);
    var presence = corner_weight(e.region.xyz, w);
    if globals.moved.w > 0.5 {
        let arrived = moved_weight(st - globals.moved_offset.xy);
        presence = arrived + (1.0 - arrived) * presence * (1.0 - moved_weight(st));
    }
    return presence * (1.0 - corner_weight(e.holes.xyz, w));
}

// The texture union with the stack's effects at parameters q of `cell`.
fn cell_sample(cell: u32, c: Cell, q: vec3<f32>, lod: f32) -> vec4<f32> {
    let tex = cell_texture(c, q);
    return with_effects(cell, q, tex, cell_world(c, q), lod, sample_union(tex, lod));
}

// d world / d(u, v, r) at q.
fn cell_jacobian(c: Cell, q: vec3<f32>) -> mat3x3<f32> {
    let w = barycentric(q);
    let x0 = c.corner[0].xyz + q.z * c.director[0].xyz;
    let x1 = c.corner[1].xyz + q.z * c.director[1].xyz;
    let x2 = c.corner[2].xyz + q.z * c.director[2].xyz;
    let pr = w.x * c.director[0].xyz + w.y * c.director[1].xyz + w.z * c.director[2].xyz;
    return mat3x3<f32>(x1 - x0, x2 - x0, pr);
}

// The exact parameters of world point x, by Newton's method from q (close already).
// Needed on the sections and side faces: the cell map is bilinear in their plane
// (the directors fan out), so the parameters the rasterizer interpolates linearly
// across their triangles are off by a share of the cell that more slices do not
// shrink. The layers r = const are exact (the map is affine on them).
fn refine(c: Cell, q0: vec3<f32>, x: vec3<f32>) -> vec3<f32> {
    var q = q0;
    for (var i = 0; i < 2; i++) {
        let j = cell_jacobian(c, q);
        let e = cell_world(c, q) - x;
        // Rows of J^{-1}: cross products of J's columns over the determinant.
        let c0 = cross(j[1], j[2]);
        let c1 = cross(j[2], j[0]);
        let c2 = cross(j[0], j[1]);
        let det = dot(j[0], c0);
        if !(abs(det) > 1e-30) {
            break;
        }
        q -= vec3<f32>(dot(c0, e), dot(c1, e), dot(c2, e)) / det;
    }
    return q;
}

struct SliceVarying {
    @builtin(position) position: vec4<f32>,
    @location(0) param: vec3<f32>,
    @location(1) world: vec3<f32>,
    @location(2) view_depth: f32,
    // (cell + 1) * 8 + face.
    @location(3) @interpolate(flat) code: u32,
    // 1 where the parameters need refining (sections and side faces).
    @location(4) @interpolate(flat) refine: u32,
};

// A slice fragment's exact cell parameters.
fn fragment_param(v: SliceVarying) -> vec3<f32> {
    if v.refine == 0u {
        return v.param;
    }
    return refine(cells[v.code / 8u - 1u], v.param, v.world);
}

// `slice`: a template vertex (u, v, r, face + 8 family); `cell`: the instance's cell.
@vertex
fn vs_slice(@location(0) slice: vec4<f32>, @location(1) cell: u32) -> SliceVarying {
    let c = cells[cell];
    let q = slice.xyz;
    let x = cell_world(c, q);
    let tag = u32(slice.w);
    let face = tag % 8u;
    var out: SliceVarying;
    out.position = globals.view_proj * vec4<f32>(x, 1.0);
    out.param = q;
    out.world = x;
    out.view_depth = -(dot(globals.view_z.xyz, x) + globals.view_z.w);
    out.code = (cell + 1u) * 8u + face;
    out.refine = select(0u, 1u, tag >= 8u || (face >= FACE_U0 && face <= FACE_W0));
    return out;
}

struct FirstHit {
    @location(0) hit: vec4<u32>,
    @location(1) depth: f32,
};

// Pass 1: the alpha test keeps the inside (alpha >= 0.5); the depth test the nearest.
@fragment
fn fs_inside(v: SliceVarying) -> FirstHit {
    let q = fragment_param(v);
    let cell = v.code / 8u - 1u;
    let c = cells[cell];
    if cell_sample(cell, c, q, cell_lod(c, v.view_depth)).a < 0.5 {
        discard;
    }
    return FirstHit(vec4<u32>(bitcast<vec3<u32>>(q), v.code), v.view_depth);
}

// Pass 2: the outside (alpha < 0.5) fragments of T1's cell in front of Z1; the
// reversed depth test keeps the farthest of them.
@fragment
fn fs_outside(v: SliceVarying) -> @location(0) vec4<f32> {
    let q = fragment_param(v);
    let cell = v.code / 8u - 1u;
    let c = cells[cell];
    if cell_sample(cell, c, q, cell_lod(c, v.view_depth)).a >= 0.5 {
        discard;
    }
    let px = vec2<i32>(floor(v.position.xy));
    let first = textureLoad(first_hit, px, 0);
    if first.w / 8u != v.code / 8u || v.view_depth >= textureLoad(first_depth, px, 0).r {
        discard;
    }
    return vec4<f32>(q, v.view_depth);
}

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let p = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(p * 2.0 - 1.0, 0.0, 1.0);
}

struct Shaded {
    // Linear colour, alpha 1 on the surface and 0 elsewhere.
    @location(0) color: vec4<f32>,
    // Unit world normal facing the camera; w: depth along the view axis.
    @location(1) normal_depth: vec4<f32>,
};

// J_world^{-T} at q, interpolated from the cell's corners (barycentric in (u, v),
// linear in r), as the paper does instead of recomputing it per fragment.
fn cell_frame(cell: u32, q: vec3<f32>) -> mat3x3<f32> {
    let w = barycentric(q);
    let f = frames[cell].corner;
    let base = f[0] * w.x + f[2] * w.y + f[4] * w.z;
    let top = f[1] * w.x + f[3] * w.y + f[5] * w.z;
    return base * (1.0 - q.z) + top * q.z;
}

// Outward parameter gradient of a face.
fn face_gradient(face: u32) -> vec3<f32> {
    switch face {
        case FACE_U0: { return vec3<f32>(-1.0, 0.0, 0.0); }
        case FACE_V0: { return vec3<f32>(0.0, -1.0, 0.0); }
        case FACE_W0: { return vec3<f32>(1.0, 1.0, 0.0); }
        case FACE_BASE: { return vec3<f32>(0.0, 0.0, -1.0); }
        default: { return vec3<f32>(0.0, 0.0, 1.0); } // FACE_TOP
    }
}

// Alpha just across `face` of `cell` at parameters q on it: in the neighbour's own
// texture coordinates (they may jump: a UV seam, one tile per face), or 0 outside
// the shell.
fn alpha_across(cell: u32, face: u32, q: vec3<f32>, lod: f32) -> f32 {
    if face == 0u || face > FACE_W0 {
        return 0.0;
    }
    let n = neighbours[cell].face[face - 1u];
    if n.x >= NO_NEIGHBOUR {
        return 0.0;
    }
    // Where q lies along the face's edge, from its corner a to its corner b.
    let w = barycentric(q);
    var t: f32;
    switch face {
        case FACE_U0: { t = w.x / (w.z + w.x); } // corner 2 to corner 0
        case FACE_V0: { t = w.y / (w.x + w.y); } // corner 0 to corner 1
        default: { t = w.z / (w.y + w.z); } // FACE_W0: corner 1 to corner 2
    }
    // The per-vertex weights are the same on both sides of the face.
    let tex = vec3<f32>(mix(n.xy, n.zw, t), q.z);
    return with_effects(cell, q, tex, cell_world(cells[cell], q), lod, sample_union(tex, lod)).a;
}

// Unit direction of the ray through the pixel centre at `frag` (window coordinates).
fn pixel_ray(frag: vec2<f32>) -> vec3<f32> {
    let ndc = vec2<f32>(frag.x * 2.0 * globals.viewport.z - 1.0, 1.0 - frag.y * 2.0 * globals.viewport.w);
    // Reversed depth: 1 on the near plane; 0.5 is farther (and finite, unlike 0 for
    // an infinite far plane).
    let near = globals.inv_view_proj * vec4<f32>(ndc, 1.0, 1.0);
    let far = globals.inv_view_proj * vec4<f32>(ndc, 0.5, 1.0);
    return normalize(far.xyz / far.w - near.xyz / near.w);
}

// Pass 3: surface point, normal and lighting per pixel, under the transparency
// pass's result (premultiplied; the output has straight alpha).
@fragment
fn fs_shade(@builtin(position) position: vec4<f32>) -> Shaded {
    var out = shade_surface(position);
    let haze = textureLoad(haze_image, vec2<i32>(floor(position.xy)), 0);
    let a = haze.a + (1.0 - haze.a) * out.color.a;
    let rgb = haze.rgb + (1.0 - haze.a) * out.color.a * out.color.rgb;
    out.color = vec4<f32>(select(vec3<f32>(0.0), rgb / a, a > 0.0), a);
    return out;
}

// The surface seen at a pixel, from T1 (and T2 when interpolating).
fn shade_surface(position: vec4<f32>) -> Shaded {
    let px = vec2<i32>(floor(position.xy));
    let first = textureLoad(first_hit, px, 0);
    if first.w == 0u {
        return Shaded(vec4<f32>(0.0), vec4<f32>(0.0));
    }
    let cell = first.w / 8u - 1u;
    let face = first.w % 8u;
    let c = cells[cell];
    let dir = pixel_ray(position.xy);
    var q = bitcast<vec3<f32>>(first.xyz);
    var depth = textureLoad(first_depth, px, 0).r;
    let lod = cell_lod(c, depth);
    var n = vec3<f32>(0.0);
    // The first inside sample on a face the ray enters the cell through: the
    // neighbour's copy of the face, just in front, was outside. Where alpha jumps
    // across the face (by more than 1/4, as the reference renderer decides), the face
    // itself is the surface, with the face's normal; otherwise the surface crossed
    // between the two copies and the gradient here gives its normal.
    var on_face = false;
    if face != 0u {
        let nf = cell_frame(cell, q) * face_gradient(face);
        if dot(nf, dir) < 0.0 && cell_sample(cell, c, q, lod).a - alpha_across(cell, face, q, lod) > 0.25 {
            on_face = true;
            n = nf;
        }
    }
    if !on_face {
        if globals.albedo.w > 0.5 {
            let second = textureLoad(second_hit, px, 0);
            if second.w > 0.0 {
                // t3 = ((a1 - 1/2) t2 - (a2 - 1/2) t1) / (a1 - a2), chapter 5.3.2.
                let a1 = cell_sample(cell, c, q, lod).a;
                let a2 = cell_sample(cell, c, second.xyz, lod).a;
                if a1 > a2 {
                    let l = clamp((a1 - 0.5) / (a1 - a2), 0.0, 1.0);
                    q = mix(q, second.xyz, l);
                    depth = mix(depth, second.w, l);
                }
            }
        }
        // d alpha / d(s, t, r) to d alpha / d(u, v, r): the transpose of the cell's
        // constant texture Jacobian.
        let g = cell_sample(cell, c, q, lod).xyz;
        n = -(cell_frame(cell, q) * texture_to_cell(c, g));
    }
    let len = length(n);
    if len > 1e-20 && len < 3.0e38 {
        n = n / len;
    } else {
        n = -dir;
    }
    if dot(n, dir) > 0.0 {
        n = -n;
    }
    return Shaded(vec4<f32>(globals.albedo.rgb * lighting(n), 1.0), vec4<f32>(n, depth));
}

// Ambient plus diffuse light on a normal of length at most 1 (shorter where the
// normals it stands for spread, which darkens rough far surfaces, chapter 6.4.4).
fn lighting(n: vec3<f32>) -> f32 {
    let ambient = globals.light.w;
    return ambient + (1.0 - ambient) * max(dot(n, globals.light.xyz), 0.0);
}

// d(s, t, r) / d(u, v, r): constant in a cell (s and t are affine in u, v; r is r).
fn texture_jacobian(c: Cell) -> mat3x3<f32> {
    return mat3x3<f32>(
        vec3<f32>(c.corner[1].w - c.corner[0].w, c.director[1].w - c.director[0].w, 0.0),
        vec3<f32>(c.corner[2].w - c.corner[0].w, c.director[2].w - c.director[0].w, 0.0),
        vec3<f32>(0.0, 0.0, 1.0),
    );
}

// A gradient in texture coordinates (s, t, r) to cell parameters (u, v, r).
fn texture_to_cell(c: Cell, g: vec3<f32>) -> vec3<f32> {
    return transpose(texture_jacobian(c)) * g;
}

// A direction in cell parameters (u, v, r) to texture coordinates (s, t, r).
fn cell_to_texture(c: Cell, d: vec3<f32>) -> vec3<f32> {
    return texture_jacobian(c) * d;
}

// The inverse of a symmetric matrix, regularized (the flattest stored ellipsoids
// are thin, never singular).
fn inverse_symmetric(m: mat3x3<f32>) -> mat3x3<f32> {
    let a = m + mat3x3<f32>(1e-3, 0.0, 0.0, 0.0, 1e-3, 0.0, 0.0, 0.0, 1e-3);
    let c0 = cross(a[1], a[2]);
    let c1 = cross(a[2], a[0]);
    let c2 = cross(a[0], a[1]);
    let det = dot(a[0], c0);
    return transpose(mat3x3<f32>(c0, c1, c2)) * (1.0 / det);
}

// The mean normal of the ellipsoid with Q^-1 = `s` (texture space) seen along the
// unit texture-space direction `d` (chapter 6.4.4, figure 6.4): the ellipsoid is
// projected along d, nine points on a 3x3 grid inside the projected ellipse are
// lifted back onto its near side, and their unit normals, carried to world space as
// gradients (`c`, `cell`, `q`: where), are averaged without normalizing.
fn ndf_normal(s: mat3x3<f32>, d: vec3<f32>, c: Cell, cell: u32, q: vec3<f32>, view: vec3<f32>) -> vec3<f32> {
    let helper = select(vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(1.0, 0.0, 0.0), abs(d.z) > 0.9);
    let e1 = normalize(cross(d, helper));
    let e2 = cross(d, e1);
    // The projected ellipse: y^T (B^T Q^-1 B)^-1 y <= 1, B = (e1, e2).
    let p = vec3<f32>(dot(e1, s * e1), dot(e1, s * e2), dot(e2, s * e2));
    let mean = 0.5 * (p.x + p.z);
    let radius = sqrt(0.25 * (p.x - p.z) * (p.x - p.z) + p.y * p.y);
    // A round ellipse has no axes of its own (and atan2(0, 0) is undefined).
    let angle = select(0.0, 0.5 * atan2(2.0 * p.y, p.x - p.z), radius > 1e-6 * max(mean, 1e-30));
    let axis1 = (cos(angle) * e1 + sin(angle) * e2) * sqrt(max(mean + radius, 0.0));
    let axis2 = (cos(angle) * e2 - sin(angle) * e1) * sqrt(max(mean - radius, 0.0));
    let qm = inverse_symmetric(s);
    let frame = cell_frame(cell, q);
    let qd = qm * d;
    let dqd = dot(d, qd);
    var sum = vec3<f32>(0.0);
    for (var i = -1; i <= 1; i++) {
        for (var j = -1; j <= 1; j++) {
            let y = 0.5 * (f32(i) * axis1 + f32(j) * axis2);
            // (y + tau d)^T Q (y + tau d) = 1, the root nearer the eye.
            let b = dot(y, qd);
            let k = dot(y, qm * y) - 1.0;
            let tau = (-b - sqrt(max(b * b - dqd * k, 0.0))) / dqd;
            var n = frame * texture_to_cell(c, qm * (y + tau * d));
            let len = length(n);
            if len > 1e-20 && len < 3.0e38 {
                n = n / len;
                if dot(n, view) > 0.0 {
                    n = -n;
                }
                sum += n;
            }
        }
    }
    return sum / 9.0;
}

// Pass 4 (double mipmaps): one transparency layer of every cell, alpha-blended over
// what the layers nearer the base left (premultiplied colour). Empty at the levels
// above the transition level, so near parts add nothing.
@fragment
fn fs_haze(v: SliceVarying) -> @location(0) vec4<f32> {
    let px = vec2<i32>(floor(v.position.xy));
    if textureLoad(first_hit, px, 0).w != 0u && v.view_depth >= textureLoad(first_depth, px, 0).r {
        discard;
    }
    let cell = v.code / 8u - 1u;
    let c = cells[cell];
    let q = v.param;
    let dims = globals.haze.xyz;
    let lod = cell_lod(c, v.view_depth) + 0.5 * log2(dims.x * dims.y);
    let level = max(lod, 0.0);
    let p = volume_coords(cell_texture(c, q), dims.z);
    let sampled = textureSampleLevel(haze_alpha, volume_sampler, p, level);
    if max(max(sampled.x, sampled.y), max(sampled.z, sampled.w)) < 1.0 / 256.0 {
        discard;
    }
    // The view ray in texture coordinates: J^-1 = frame^T carries world directions to
    // cell parameters.
    let view = pixel_ray(v.position.xy);
    let frame = cell_frame(cell, q);
    let d = cell_to_texture(c, transpose(frame) * view);
    // Between two layers (1 / count apart in r) the ray runs 1 / (count |d_r|) in
    // texture units and crosses |d_i| dims_i of that texels along each axis (dims at
    // this level); each crossing lets 1 - alpha_i through.
    // Along r, the column's alpha spread evenly over its rows (blending cannot
    // correlate layers; this keeps a view along the directors exact).
    let level_dims = max(dims * exp2(-level), vec3<f32>(1.0));
    let between = (1.0 / globals.mip.w) / max(abs(d.z), 1e-6);
    let crossings = min(abs(d) * level_dims * between, vec3<f32>(64.0));
    let per_row = log2(max(1.0 - sampled.w, 1e-6)) / level_dims.z;
    let log_through = vec3<f32>(log2(max(vec2<f32>(1.0) - sampled.xy, vec2<f32>(1e-6))), per_row);
    let through = exp2(crossings * log_through);
    let opacity = clamp(1.0 - through.x * through.y * through.z, 0.0, 1.0) * texture_share(cell, q, cell_texture(c, q).xy, cell_world(c, q));
    if opacity < 1.0 / 512.0 {
        discard;
    }
    let diagonal = textureSampleLevel(haze_ndf_diagonal, volume_sampler, p, level).xyz;
    let off = textureSampleLevel(haze_ndf_off_diagonal, volume_sampler, p, level).xyz;
    let s = mat3x3<f32>(
        vec3<f32>(diagonal.x, off.x, off.y),
        vec3<f32>(off.x, diagonal.y, off.z),
        vec3<f32>(off.y, off.z, diagonal.z),
    );
    let n = ndf_normal(s, normalize(d), c, cell, q, view);
    return vec4<f32>(globals.albedo.rgb * lighting(n) * opacity, opacity);
}
