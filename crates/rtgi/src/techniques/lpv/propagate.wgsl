// One propagation step (prepended: volume.wgsl), gathered per destination cell: each of its 6
// neighbours sends its light through the 5 faces of this cell that it sees (all but the shared one).
// The flux through a face is ΔΩ_f · I(ω_c), the face's solid angle seen from the source's centre
// (FRONT_SOLID_ANGLE for the far face, SIDE_SOLID_ANGLE for the four side faces: together 2π/3, so the
// six neighbours of a cell share its whole sphere) times the source's intensity towards the face's
// centre; it is re-emitted from this cell's centre as a cosine lobe towards that face, intensity
// Φ_f/π ⟨n_f, ω⟩⁺ (Kaplanyan & Dachsbacher 2010, §3.3). With GEOMETRY_VOLUME, light reaching a face
// is attenuated by 1 − B(ω_c), the blocking potential interpolated at the face between the two cells,
// except in the first step (the injected light would be blocked by the surfaces it leaves).
//
// MULTIPLE_BOUNCES (the paper's §5.2): the light a cell sends towards a neighbour and the geometry
// between them blocks is not lost but reflected back into the cell by the blockers' mean albedo ρ, as a
// cosine lobe about the face's normal facing the cell (the cell-face discretisation's surface normal):
// Φ_f · B(ω_c) · ρ per face f, so with ρ = 1 a step only redirects light (what the face transmits plus
// what it reflects is what reached it). The reflected light propagates on in the next steps, and its
// blocked part is reflected again: every bounce that fits in the iterations.

@group(2) @binding(3) var<storage, read_write> source: array<vec4f>;
@group(2) @binding(4) var<storage, read_write> destination: array<vec4f>;
@group(2) @binding(5) var<storage, read_write> accumulated: array<vec4f>;
@group(2) @binding(6) var<storage, read_write> geometry: array<vec4f>;
@group(2) @binding(8) var<uniform> propagation: PropagationStep;

const AXES = array<vec3i, 6>(
    vec3i(1, 0, 0), vec3i(-1, 0, 0), vec3i(0, 1, 0), vec3i(0, -1, 0), vec3i(0, 0, 1), vec3i(0, 0, -1),
);

fn load_light(i: u32) -> CellLight {
    return CellLight(source[3u * i], source[3u * i + 1u], source[3u * i + 2u]);
}

// The geometry volume of `cascade` at grid position g (its cells are centred on whole grid positions):
// `slot` 0 the blocking potential, 1 the albedo.
fn geometry_at(cascade: u32, g: vec3f, slot: u32) -> vec4f {
    let base = clamp(floor(g), vec3f(0.0), vec3f(f32(GRID - 1u)));
    let f = clamp(g - base, vec3f(0.0), vec3f(1.0));
    let b = vec3u(base);
    var sum = vec4f(0.0);
    for (var k = 0u; k < 8u; k++) {
        let corner = vec3u(k & 1u, (k >> 1u) & 1u, k >> 2u);
        let w = select(1.0 - f, f, corner == vec3u(1u));
        sum += geometry[GEOMETRY_SLOTS * geometry_index(cascade, b + corner) + slot] * (w.x * w.y * w.z);
    }
    return sum;
}

// Light a source cell sends towards the neighbour along `dir` through that neighbour's face `face`:
// the direction from the source's centre to the face's centre, and the face's solid angle from there.
fn towards_face(dir: vec3i, face: vec3i) -> vec3f {
    return normalize(vec3f(dir) + 0.5 * vec3f(face));
}

fn face_solid_angle(dir: vec3i, face: vec3i) -> f32 {
    return select(SIDE_SOLID_ANGLE, FRONT_SOLID_ANGLE, all(face == dir));
}

// Re-emits `flux` (per channel) as a cosine lobe about `normal`: intensity Φ/π ⟨normal, ω⟩⁺.
fn add_lobe(sum: ptr<function, CellLight>, normal: vec3f, flux: vec3f) {
    let lobe = sh4_cosine_lobe(normal) * INV_PI;
    (*sum).r += lobe * flux.r;
    (*sum).g += lobe * flux.g;
    (*sum).b += lobe * flux.b;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let i = indirect_linear_index(gid, groups, 64u);
    if i >= lpv.cascade_count * cells_per_cascade() {
        return;
    }
    let cascade = i / cells_per_cascade();
    let cell = vec3i(cell_of(cascade, i));
    let occluded = GEOMETRY_VOLUME && propagation.index > 0u;
    var gathered = CellLight(vec4f(0.0), vec4f(0.0), vec4f(0.0));
    for (var a = 0u; a < 6u; a++) {
        // Light travelling along `dir` from the neighbour behind this cell.
        let dir = AXES[a];
        let neighbour = cell - dir;
        if any(neighbour < vec3i(0)) || any(neighbour >= vec3i(i32(GRID))) {
            continue;
        }
        let light = load_light(cell_index(cascade, vec3u(neighbour)));
        var blocking = vec4f(0.0);
        if occluded {
            blocking = geometry_at(cascade, vec3f(cell) + 0.5 - 0.5 * vec3f(dir), 0u);
        }
        for (var f = 0u; f < 6u; f++) {
            let face = AXES[f];
            if all(face == -dir) {
                continue;
            }
            let towards = towards_face(dir, face);
            var flux = max(eval_cell(light, towards), vec3f(0.0)) * face_solid_angle(dir, face);
            if occluded {
                flux *= 1.0 - saturate(dot(blocking, sh4_basis(towards)));
            }
            add_lobe(&gathered, vec3f(face), flux);
        }
    }
    if MULTIPLE_BOUNCES && occluded {
        // This cell's own light towards each neighbour, the part the face between them blocks.
        let own = load_light(i);
        for (var a = 0u; a < 6u; a++) {
            let dir = AXES[a];
            let next = cell + dir;
            if any(next < vec3i(0)) || any(next >= vec3i(i32(GRID))) {
                continue;
            }
            let face_centre = vec3f(cell) + 0.5 + 0.5 * vec3f(dir);
            let blocking = geometry_at(cascade, face_centre, 0u);
            var blocked = vec3f(0.0);
            for (var f = 0u; f < 6u; f++) {
                let face = AXES[f];
                if all(face == -dir) {
                    continue;
                }
                let towards = towards_face(dir, face);
                blocked += max(eval_cell(own, towards), vec3f(0.0)) * face_solid_angle(dir, face)
                    * saturate(dot(blocking, sh4_basis(towards)));
            }
            let albedo = geometry_at(cascade, face_centre, 1u);
            add_lobe(&gathered, -vec3f(dir), select(vec3f(0.0), albedo.rgb / albedo.w, albedo.w > 0.0) * blocked);
        }
    }
    destination[3u * i] = gathered.r;
    destination[3u * i + 1u] = gathered.g;
    destination[3u * i + 2u] = gathered.b;
    accumulated[3u * i] += gathered.r;
    accumulated[3u * i + 1u] += gathered.g;
    accumulated[3u * i + 2u] += gathered.b;
}
