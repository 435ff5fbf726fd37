//! The merge's culling by the baked maps' cells (`map_cells.rs`) is exact:
//! on the bundled grid of rooms (moving spheres, walls and doorways
//! between the rooms), every map the cells say hides the spheres gets,
//! when merged anyway, a tile no nearer than its baked map at any texel —
//! so leaving it out changes no lookup. And some maps are left out.

use gibake_bake::cluster::ClusterTarget;
use gibake_gpu::mesh::SceneGpu;
use gibake_gpu::{GpuContext, readback};
use gibake_scene::{LoadOptions, Sun};
use glam::Vec3;

use super::VplMerge;
use crate::baked::BakedGpu;
use crate::map_cells::MapCells;

#[test]
fn the_maps_the_cells_leave_out_would_not_change() {
    let ctx = GpuContext::new(&Default::default()).unwrap_or_else(|e| {
        panic!(
            "this test needs a GPU adapter ({e}); `apt-get install mesa-vulkan-drivers` gives the \
             lavapipe software GPU"
        )
    });
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/levels/rooms/rooms.glb");
    let options = LoadOptions {
        sun: Some(Sun {
            azimuth_deg: 296.9,
            elevation_deg: 17.0,
            irradiance: 3.0,
            color: Vec3::ONE,
        }),
        dynamic: vec!["Room/Sphere.00?".into()],
        ..Default::default()
    };
    let scene = gibake_scene::load(&path, &options).expect("load the rooms level");
    assert!(!scene.dynamic_objects.is_empty());
    let opts = gibake_bake::BakeOptions {
        rsm_size: 128,
        vpl_map_size: 32,
        shadow_map_size: 512,
        target: ClusterTarget::Count(64),
        bounces: gibake_bake::later::Bounces::Count(1),
        later_vpls: None,
    };
    let asset = gibake_bake::bake(&ctx, &scene, &opts, &gibake_bake::NoProgress, "test")
        .expect("bake")
        .asset;
    let baked = BakedGpu::new(&ctx.device, &ctx.queue, &asset).expect("upload");
    let cells = MapCells::new(&asset, &baked);
    let scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, &scene, 0.5);
    let transforms = scene.dynamic_transforms(0.5);
    let diagonal = scene.full_bounds().diagonal();
    // Merged without the cells: every map a sphere reaches gets a tile.
    let mut merge = VplMerge::new(
        &ctx.device,
        &scene_gpu,
        &baked,
        diagonal,
        false,
        0.0,
        Vec::new(),
    )
    .expect("the merge");
    assert!(
        merge.cells.is_none(),
        "the asset's cells are only set by the world"
    );
    let moving = scene_gpu.dynamic_draws.clone();
    merge
        .prepare(&ctx.device, &ctx.queue, &scene_gpu, &moving, &transforms)
        .expect("prepare");
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    merge.record(&mut enc, None);
    ctx.queue.submit([enc.finish()]);
    let atlas = &merge.atlas;
    let tiles = readback::read_texture_f32(&ctx, &atlas.texture, 0, 1).expect("read the atlas");
    let width = (atlas.cols * atlas.tile_size) as usize;
    let s = baked.map_size as usize;
    let boxes: Vec<gibake_scene::Aabb> = moving
        .iter()
        .map(|d| match d.object.and_then(|o| transforms.get(o)) {
            Some(m) => d.bounds.transformed(*m),
            None => d.bounds,
        })
        .collect();
    let (mut hidden, mut checked_texels) = (0, 0u64);
    for (v, frame) in merge.frames.iter().enumerate() {
        let (Some((o, n)), Some(slot)) = (frame, merge.tiles.get(v).filter(|&&t| t != u32::MAX))
        else {
            continue;
        };
        if !boxes.iter().all(|b| cells.hides(v, *o, *n, b)) {
            continue;
        }
        hidden += 1;
        let map = if v < baked.vpls.len() {
            asset.vpl_maps.map(baked.vpls[v].map)
        } else {
            let i = v - baked.vpls.len();
            asset.vpl_lower_maps.map(asset.vpl_lower[i].map)
        }
        .expect("a hidden frame has a baked map");
        let [tx, ty] = atlas.tile_origin(*slot);
        for y in 0..s {
            for x in 0..s {
                let merged = tiles[(ty as usize + y) * width + tx as usize + x];
                // The atlas is cleared to the largest finite distance.
                let stored = map[y * s + x].min(f32::MAX);
                assert!(
                    merged >= stored,
                    "frame {v} texel ({x}, {y}): the sphere at {merged} before the baked surface at {stored}"
                );
                checked_texels += 1;
            }
        }
    }
    assert!(
        hidden > 0,
        "no map of the {} reached hides the spheres",
        merge.affected()
    );
    assert!(
        hidden < merge.affected(),
        "every reached map hidden: the test checks nothing drawn"
    );
    eprintln!(
        "{hidden} of {} reached maps hidden, {checked_texels} texels checked",
        merge.affected()
    );
}
