// Non-linear approximation: one workgroup keeps a row's `kept` largest coefficients of `haar_out`
// (by the composer's `magnitude`), in index order, calling the composer's `keep_term(row, slot,
// index)` for slots 0.. of the kept ones. The threshold is found bit by bit on the magnitudes' bit
// patterns (monotonic for floats ≥ 0): t is the largest value with at least `kept` magnitudes ≥ t.
// Every magnitude above t is kept, then those equal to t (ties) in index order until `kept` are:
// the result does not depend on the invocations' timing. Zeros are never kept.

const SELECT_LANES: u32 = 64u;

var<workgroup> select_tally: atomic<u32>;
var<workgroup> select_total: u32;
var<workgroup> select_above: array<u32, SELECT_LANES>;
var<workgroup> select_ties: array<u32, SELECT_LANES>;

fn magnitude_bits(row: u32, index: u32) -> u32 {
    return bitcast<u32>(magnitude(haar_out[row * CUBE_TEXELS + index], index));
}

// The row's magnitudes ≥ `threshold` (the same in every invocation).
fn count_at_least(row: u32, threshold: u32, lane: u32) -> u32 {
    var count = 0u;
    for (var i = lane; i < CUBE_TEXELS; i += SELECT_LANES) {
        count += u32(magnitude_bits(row, i) >= threshold);
    }
    if lane == 0u {
        atomicStore(&select_tally, 0u);
    }
    workgroupBarrier();
    atomicAdd(&select_tally, count);
    workgroupBarrier();
    if lane == 0u {
        select_total = atomicLoad(&select_tally);
    }
    return workgroupUniformLoad(&select_total);
}

fn select_terms(row: u32, kept: u32, lane: u32) {
    var threshold = 0u;
    for (var bit = 31u; bit > 0u; bit--) {
        let candidate = threshold | (1u << (bit - 1u));
        if count_at_least(row, candidate, lane) >= kept {
            threshold = candidate;
        }
    }
    // Each invocation compacts a contiguous range, so that slots follow the index order.
    let span = CUBE_TEXELS / SELECT_LANES;
    let first = lane * span;
    var above = 0u;
    var ties = 0u;
    for (var i = first; i < first + span; i++) {
        let m = magnitude_bits(row, i);
        above += u32(m > threshold);
        ties += u32(m == threshold && threshold > 0u);
    }
    select_above[lane] = above;
    select_ties[lane] = ties;
    workgroupBarrier();
    if lane == 0u {
        var above_sum = 0u;
        var ties_sum = 0u;
        for (var l = 0u; l < SELECT_LANES; l++) {
            let a = select_above[l];
            let t = select_ties[l];
            select_above[l] = above_sum;
            select_ties[l] = ties_sum;
            above_sum += a;
            ties_sum += t;
        }
        select_total = above_sum;
    }
    workgroupBarrier();
    var above_slot = select_above[lane];
    var tie_slot = select_total + select_ties[lane];
    for (var i = first; i < first + span; i++) {
        let m = magnitude_bits(row, i);
        if m > threshold {
            keep_term(row, above_slot, i);
            above_slot++;
        } else if m == threshold && threshold > 0u {
            if tie_slot < kept {
                keep_term(row, tie_slot, i);
            }
            tie_slot++;
        }
    }
}
