// One level of the illumination trees, bottom-up: a leaf takes its sample's E·A, an inner node sums
// its children and places itself at their luminance-weighted mean position (the area-weighted one
// when neither child is lit), as Jensen & Buhler's nodes, and sums the luminance-weighted directions
// and normals the directional dipole takes from it; the bounds are refitted on the way, for
// samples that moved with their meshes.

#import common/color.wgsl

struct Level {
    offset: u32,
    count: u32,
}
@group(3) @binding(0) var<uniform> level: Level;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= level.count {
        return;
    }
    let n = node_order[level.offset + id.x];
    let node = nodes[n];
    var light: NodeLight;
    if node.count == 1u {
        let s = samples[node.first];
        let sample = sample_light[node.first];
        light.power = sample.irradiance * s.area;
        light.position = s.position;
        light.direction = sample.direction * s.area;
        light.normal = s.normal * luminance(light.power);
        nodes[n].lo = s.position;
        nodes[n].hi = s.position;
    } else {
        let a = node_light[n + 1u];
        let b = node_light[node.right];
        light.power = a.power + b.power;
        var wa = luminance(a.power);
        var wb = luminance(b.power);
        if wa + wb <= 0.0 {
            wa = nodes[n + 1u].area;
            wb = nodes[node.right].area;
        }
        light.position = (wa * a.position + wb * b.position) / (wa + wb);
        light.direction = a.direction + b.direction;
        light.normal = a.normal + b.normal;
        nodes[n].lo = min(nodes[n + 1u].lo, nodes[node.right].lo);
        nodes[n].hi = max(nodes[n + 1u].hi, nodes[node.right].hi);
    }
    node_light[n] = light;
}
