use std::collections::BTreeMap;
use std::mem::offset_of;

use super::*;
use crate::gpu::TimingMode;
use crate::shaders::layout::assert_layout;
use crate::shaders::validate;
use crate::techniques::fixture::fixture;

#[test]
fn shaders_validate_and_mirror_the_host_layouts() {
    let m = validate(
        "photon map build",
        &format!("{VPL_WGSL}\n{PHOTON_WGSL}\n{GRID_WGSL}"),
        &grid_defines(Defines::new(), 0.1, 1024),
    );
    assert_layout(
        &m,
        "Photon",
        size_of::<GpuPhoton>(),
        &[
            ("position", offset_of!(GpuPhoton, position)),
            ("source", offset_of!(GpuPhoton, source)),
            ("flux", offset_of!(GpuPhoton, flux)),
            ("incoming", offset_of!(GpuPhoton, incoming)),
            ("normal", offset_of!(GpuPhoton, normal)),
        ],
    );
    assert_layout(
        &m,
        "PhotonBuild",
        size_of::<PhotonBuild>(),
        &[("first", offset_of!(PhotonBuild, first)), ("end", offset_of!(PhotonBuild, end))],
    );
}

/// The WGSL hash of a cell (common/random.wgsl's hash3), for checking the grid on the CPU.
fn bucket_of(cell: [i32; 3], buckets: u32) -> u32 {
    let pcg = |v: u32| {
        let state = v.wrapping_mul(747796405).wrapping_add(2891336453);
        let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277803737);
        (word >> 22) ^ word
    };
    let [a, b, c] = cell.map(|x| x as u32);
    pcg(a ^ pcg(b ^ pcg(c))) & (buckets - 1)
}

/// After a build on the Cornell box every photon (surface vertex 2 or deeper with flux) sits once in
/// the bucket of its cell, each bucket in VPL order, and the bucket starts are the running counts.
#[test]
fn the_grid_holds_every_photon_once_in_its_bucket_in_vpl_order() {
    let fx = fixture("cornell", 16, 16);
    let settings = PhotonSettings { paths: 4096, depth: 8, radius_fraction: 0.04 };
    let map = PhotonMap::new(&fx.setup(&ParamValues::default()), settings).expect("photon map");
    let mut profiler = Profiler::new(&fx.ctx, TimingMode::Passes);
    let fc = FrameContext::still(&fx.ctx, &fx.gpu_scene, &fx.frame);
    map.build(&fc, &mut profiler).expect("build");

    let read =
        |buffer: &wgpu::Buffer| readback::read_buffer(&fx.ctx, buffer, 0, buffer.size()).expect("read");
    let vpl_bytes = read(&map.vpls);
    let vpls: &[GpuVpl] = bytemuck::cast_slice(&vpl_bytes);
    let grid_bytes = read(&map.grid);
    let grid: &[u32] = bytemuck::cast_slice(&grid_bytes);
    let photon_bytes = read(&map.photons);
    let photons: &[GpuPhoton] = bytemuck::cast_slice(&photon_bytes);
    let b = map.buckets as usize;

    // The photons the VPL buffer holds: vertices 2.., on surfaces, with flux.
    let first = map.first as usize;
    let expected: BTreeMap<u32, &GpuVpl> = (first..first + map.slots as usize)
        .filter(|&i| vpls[i].kind == 1 && vpls[i].flux.iter().any(|&f| f > 0.0))
        .map(|i| (i as u32, &vpls[i]))
        .collect();
    // Measured: 904 (the box is open towards the camera; light paths leave it).
    assert!(expected.len() > 500, "{} photons from 4096 paths", expected.len());
    assert_eq!(grid[b] as usize, expected.len());
    assert_eq!(map.stored(&fx.ctx).expect("count") as usize, expected.len());

    let mut seen = BTreeMap::new();
    let mut off_boundary = 0;
    for bucket in 0..b {
        let (begin, end) = (grid[bucket] as usize, grid[bucket + 1] as usize);
        assert!(begin <= end && end <= grid[b] as usize);
        for i in begin..end {
            let p = &photons[i];
            if i > begin {
                assert!(photons[i - 1].source < p.source, "bucket {bucket} out of VPL order");
            }
            let v = expected.get(&p.source).expect("a photon from a photon slot");
            assert_eq!(
                (p.position, p.flux, p.incoming, p.normal),
                (v.position, v.flux, v.incoming, v.normal)
            );
            assert!(seen.insert(p.source, bucket).is_none(), "photon {} twice", p.source);
            // The cell on the CPU, where no coordinate is within rounding of a cell boundary.
            let g = p.position.map(|x| x / (2.0 * map.radius));
            if g.iter().all(|x| (x - x.round()).abs() > 1e-4) {
                assert_eq!(bucket_of(g.map(|x| x.floor() as i32), map.buckets) as usize, bucket);
                off_boundary += 1;
            }
        }
    }
    assert_eq!(seen.len(), expected.len());
    assert!(off_boundary * 10 > expected.len() * 9);
}
