// `photon-irradiance-cache` with `record_irradiance=photon_density`: a record's hemisphere cells from
// the photons alone, no rays (the thesis's Algorithm 7, Brouillat 2006; report §5).
//   1. A first query within PHOTON_RADIUS estimates R as the harmonic mean of the photons' travelled
//      distances d (how far the surface that sent each one lies).
//   2. The second query gathers the photons within r = a·R, clamped to [1, MAX_GATHER_RADII] photon
//      radii so that it reads at most (MAX_GATHER_RADII + 1)³ grid cells, on surfaces facing like the
//      record with light arriving from above it, and updates R from them.
//   3. The area they cover is the convex hull of their projections on the tangent plane, not the disc
//      π r² (which biases records low at borders and in corners, where photons fill part of the
//      disc). A hull of n points from a region shrinks inside it; the thesis corrects it by a formula
//      given only in [Bro06]; rtgi uses Efron's (1965) identity E[A_hull(n)] = A (1 − E[V_{n+1}] /
//      (n + 1)) with the hull's vertex count V for E[V], and caps the result at the disc. The hull is
//      the polygon of the photons extreme along HULL_DIRECTIONS directions (one per thread): an inner
//      polygon of the exact hull with at most HULL_DIRECTIONS vertices.
//   4. Each cell gets the radiance its photons carry, Eq. 6.11: L = 2 Φ_cell / (A (cos²θ− − cos²θ+)
//      (φ+ − φ−)) = Φ_cell M N / (π A) for cells of equal cos²-measure, so Σ_cells L π / (M N) = Σ Φ / A
//      (Eq. 6.2), and the flux-weighted mean 1/d of its photons; the gradients then come from the same
//      cells as a traced record's. Cells no photon reached are dark (the thesis's gradient noise).
// Records on glossy surfaces project the same cells onto HSH.

const HULL_DIRECTIONS: u32 = RECORD_THREADS;
const NO_PHOTON: u32 = 0xffffffffu;
// A chunk's photon that is not gathered.
const NO_CELL: u32 = 0xffffffffu;
const CHUNK_STEPS: u32 = RECORD_THREADS / 4u;

// One chunk of RECORD_THREADS photons, four to a vector (see gather_photons): their tangent-plane
// points and hemisphere cells (NO_CELL: not gathered). After a query the same memory holds each
// thread's tally (photons in x, their Σ 1/d in y) and, in chunk_cell, the extreme photon of its
// direction: the record pass has no workgroup memory to spare at its largest hemisphere.
var<workgroup> chunk_x: array<vec4f, CHUNK_STEPS>;
var<workgroup> chunk_y: array<vec4f, CHUNK_STEPS>;
var<workgroup> chunk_cell: array<vec4u, CHUNK_STEPS>;
// The second query's radius, then (R, covered area) of the record.
var<workgroup> photon_gather: vec2f;

// Keeps photon i if it lies farther along the thread's direction than the extreme so far (the first
// of equals, as photons come in index order).
fn keep_extreme(farthest: ptr<function, f32>, extreme: ptr<function, u32>, along: f32, gathered: bool, i: u32) {
    if gathered && along > *farthest {
        *farthest = along;
        *extreme = i;
    }
}

// Adds photon i to hemisphere cell `cell` if the thread owns that cell.
fn add_to_cell(mine: bool, cell: u32, i: u32) {
    if mine {
        let p = photons[i];
        let weight = p.flux.r + p.flux.g + p.flux.b;
        cell_radiance[cell] += p.flux;
        cell_inverse_distance[cell] += weight * (1.0 / max(p.travelled, 1e-6));
    }
}

// Photons within `radius` of the record that light it (see 2.). lavapipe ends an invocation after
// 65535 loop iterations, and a bright corner's query holds 10⁵ photons, so no thread reads them all:
// the workgroup takes each bucket in chunks of RECORD_THREADS photons, one per thread, which tests
// its photon and tallies it. With `full` the threads then scan the chunk four photons a step (a
// sixteenth of the iterations of reading them one by one): each adds the photons of its own cells
// (cell % RECORD_THREADS == thread, as elsewhere in the record pass) and finds the extreme photon of
// its direction. Cells and extremes see the photons in index order, as a single reader would.
fn gather_photons(rs: RecordSurface, radius: f32, thread: u32, full: bool) {
    let lo = photon_cell(rs.position - vec3f(radius));
    let hi = photon_cell(rs.position + vec3f(radius));
    let r2 = radius * radius;
    let angle = 2.0 * PI * f32(thread) / f32(HULL_DIRECTIONS);
    let axis = vec2f(cos(angle), sin(angle));
    var farthest = -FLT_MAX;
    var extreme = NO_PHOTON;
    var tally = vec2f(0.0);
    for (var z = lo.z; z <= hi.z; z++) {
        for (var y = lo.y; y <= hi.y; y++) {
            for (var x = lo.x; x <= hi.x; x++) {
                let cell = vec3i(x, y, z);
                let bucket = photon_bucket(cell);
                let end = photon_grid[bucket + 1u];
                for (var base = photon_grid[bucket]; base < end; base += RECORD_THREADS) {
                    let i = base + thread;
                    var hemisphere_cell = NO_CELL;
                    var q = vec2f(0.0);
                    if i < end {
                        let p = photons[i];
                        let offset = p.position - rs.position;
                        let arriving = world_to_local(p.incoming, rs.normal);
                        // A bucket holds every cell hashing to it: each photon is read with its own cell.
                        if dot(offset, offset) < r2 && dot(p.normal, rs.normal) > PHOTON_NORMAL_COS
                            && all(photon_cell(p.position) == cell) && arriving.z > 0.0 {
                            tally += vec2f(1.0, 1.0 / max(p.travelled, 1e-6));
                            hemisphere_cell = cell_of(arriving);
                            q = world_to_local(offset, rs.normal).xy;
                        }
                    }
                    if !full {
                        continue;
                    }
                    chunk_x[thread / 4u][thread % 4u] = q.x;
                    chunk_y[thread / 4u][thread % 4u] = q.y;
                    chunk_cell[thread / 4u][thread % 4u] = hemisphere_cell;
                    workgroupBarrier();
                    for (var s = 0u; s < CHUNK_STEPS; s++) {
                        let cells = chunk_cell[s];
                        let gathered = cells != vec4u(NO_CELL);
                        let along = chunk_x[s] * axis.x + chunk_y[s] * axis.y;
                        let first = base + 4u * s;
                        keep_extreme(&farthest, &extreme, along.x, gathered.x, first);
                        keep_extreme(&farthest, &extreme, along.y, gathered.y, first + 1u);
                        keep_extreme(&farthest, &extreme, along.z, gathered.z, first + 2u);
                        keep_extreme(&farthest, &extreme, along.w, gathered.w, first + 3u);
                        let mine = gathered & (cells % RECORD_THREADS == vec4u(thread));
                        if any(mine) {
                            add_to_cell(mine.x, cells.x, first);
                            add_to_cell(mine.y, cells.y, first + 1u);
                            add_to_cell(mine.z, cells.z, first + 2u);
                            add_to_cell(mine.w, cells.w, first + 3u);
                        }
                    }
                    workgroupBarrier();
                }
            }
        }
    }
    chunk_x[thread / 4u][thread % 4u] = tally.x;
    chunk_y[thread / 4u][thread % 4u] = tally.y;
    if full {
        chunk_cell[thread / 4u][thread % 4u] = extreme;
    }
}

// Σ over the threads' tallies, in thread order: (photons, Σ 1/d).
fn photon_totals() -> vec2f {
    var sum = vec2f(0.0);
    for (var t = 0u; t < RECORD_THREADS; t++) {
        sum += vec2f(chunk_x[t / 4u][t % 4u], chunk_y[t / 4u][t % 4u]);
    }
    return sum;
}

fn cross2(a: vec2f, b: vec2f) -> f32 {
    return a.x * b.y - a.y * b.x;
}

// The polygon of the extreme photons (directions in counter-clockwise order give its vertices in
// order, each over a run of directions): (area, vertices).
fn extreme_polygon(rs: RecordSurface) -> vec2f {
    var twice_area = 0.0;
    var vertices = 0u;
    var first = NO_PHOTON;
    var previous = NO_PHOTON;
    var first_q = vec2f(0.0);
    var previous_q = vec2f(0.0);
    for (var t = 0u; t < HULL_DIRECTIONS; t++) {
        let e = chunk_cell[t / 4u][t % 4u];
        // A vertex's run of directions may wrap past the last one back to the first.
        if e == NO_PHOTON || e == previous || e == first {
            continue;
        }
        let q = world_to_local(photons[e].position - rs.position, rs.normal).xy;
        if previous == NO_PHOTON {
            first = e;
            first_q = q;
        } else {
            twice_area += cross2(previous_q, q);
        }
        previous = e;
        previous_q = q;
        vertices++;
    }
    twice_area += cross2(previous_q, first_q);
    return vec2f(0.5 * twice_area, f32(vertices));
}

// The area the n gathered photons cover (see 3.).
fn covered_area(rs: RecordSurface, n: f32, radius: f32) -> f32 {
    let disc = PI * radius * radius;
    let polygon = extreme_polygon(rs);
    if polygon.y < 3.0 || polygon.x <= 0.0 {
        return disc;
    }
    return min(polygon.x / (1.0 - polygon.y / (n + 1.0)), disc);
}

// Fills cell_radiance / cell_inverse_distance from the photons (every thread of the record's
// workgroup calls it) and leaves (R, area) in photon_gather.
fn gather_photon_cells(rs: RecordSurface, thread: u32) {
    for (var cell = thread; cell < CELLS; cell += RECORD_THREADS) {
        cell_radiance[cell] = vec3f(0.0);
        cell_inverse_distance[cell] = 0.0;
    }
    let accuracy = kind_accuracy(rs.glossy);
    gather_photons(rs, PHOTON_RADIUS, thread, false);
    workgroupBarrier();
    if thread == 0u {
        let first = photon_totals();
        // Without photons near, look as far as a query may.
        var radius = MAX_GATHER_RADII * PHOTON_RADIUS;
        if first.y > 0.0 {
            radius = clamp(accuracy * first.x / first.y, PHOTON_RADIUS, radius);
        }
        photon_gather = vec2f(radius, 0.0);
    }
    let radius = workgroupUniformLoad(&photon_gather).x;
    gather_photons(rs, radius, thread, true);
    workgroupBarrier();
    if thread == 0u {
        let totals = photon_totals();
        // Where no photon arrives the record claims only the disc it looked at.
        var harmonic = radius / accuracy;
        if totals.y > 0.0 {
            harmonic = totals.x / totals.y;
        }
        photon_gather = vec2f(harmonic, covered_area(rs, totals.x, radius));
    }
    let area = workgroupUniformLoad(&photon_gather).y;
    for (var cell = thread; cell < CELLS; cell += RECORD_THREADS) {
        let flux = cell_radiance[cell];
        let weight = flux.r + flux.g + flux.b;
        cell_inverse_distance[cell] = select(0.0, cell_inverse_distance[cell] / weight, weight > 0.0);
        cell_radiance[cell] = flux * f32(CELLS) / (PI * area);
    }
}
