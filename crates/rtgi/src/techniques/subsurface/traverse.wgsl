// One traversal of a mesh's illumination tree per pixel cluster (Jensen & Buhler 2002, with the dual
// tree's cluster test): a node is used whole when the solid angle of its area seen from the cluster's
// mean position, A / |p − p_node|², is below ε and its bounds do not meet the cluster's (the sphere
// holding its pixels; for one pixel, Jensen & Buhler's test that the pixel lies outside the node's
// box); leaves (one sample each) are always used. With ε = 0 every sample is summed: the brute-force reference.

#import common/indirect.wgsl

const STACK: u32 = 32u;

fn sphere_meets_box(center: vec3f, radius: f32, lo: vec3f, hi: vec3f) -> bool {
    let d = clamp(center, lo, hi) - center;
    return dot(d, d) <= radius * radius;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let j = indirect_linear_index(id, groups, 64u);
    if j >= atomicLoad(&counters[COUNTER_JOBS]) {
        return;
    }
    let job = jobs[j];
    let medium = media[job.material];
    let root = mesh_roots[job.mesh];
    var sum = vec3f(0.0);
    var evaluations = 0u;
    var visits = 0u;
    var stack: array<u32, STACK>;
    var top = 0u;
    if root != NO_NODE {
        stack[0] = root;
        top = 1u;
    }
    while top > 0u {
        top -= 1u;
        let n = stack[top];
        visits += 1u;
        let light = node_light[n];
        if all(light.power == vec3f(0.0)) {
            continue;
        }
        let node = nodes[n];
        let offset = light.position - job.center;
        let d2 = dot(offset, offset);
        let far = node.area < EPSILON * d2 && !sphere_meets_box(job.center, job.radius, node.lo, node.hi);
        if node.count == 1u || far {
            if DIRECTIONAL {
                let w12 = normalize(light.direction);
                let n_i = normalize(light.normal);
                sum += directional_dipole(medium, light.position, n_i, w12, job.center, job.normal) * light.power;
            } else {
                sum += dipole_profile(medium, sqrt(d2)) * light.power;
            }
            evaluations += 1u;
        } else {
            stack[top] = node.right;
            stack[top + 1u] = n + 1u;
            top += 2u;
        }
    }
    // llvmpipe ends any loop after 65535 iterations of one invocation (its guard against endless
    // loops): a walk cut short there is counted, not hidden.
    if top > 0u {
        atomicAdd(&counters[COUNTER_TRUNCATED], 1u);
    }
    job_light[j] = vec4f(sum, 0.0);
    atomicAdd(&counters[COUNTER_EVALUATIONS], evaluations);
    atomicAdd(&counters[COUNTER_VISITS], visits);
}
