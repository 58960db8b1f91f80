// Which mesh a triangle of the scene belongs to, by binary search in `mesh_starts`: (first triangle,
// mesh) of every non-empty mesh, by first triangle (frame::mesh_starts builds it). The including shader
// declares `mesh_starts: array<vec2u>` in its own bind group.

fn mesh_of_triangle(triangle: u32) -> u32 {
    var lo = 0u;
    var hi = arrayLength(&mesh_starts);
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if mesh_starts[mid].x <= triangle {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return mesh_starts[lo].y;
}
