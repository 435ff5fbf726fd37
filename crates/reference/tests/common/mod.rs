//! Helpers shared by the reference's test files.

use gibake_image::Image;
use gibake_reference::{Depth, RayScene, Settings, View, render_view};
use gibake_scene::{Projection, Scene};
use glam::Vec3;

/// Render settings at time 0 with `seed`.
pub fn settings_seeded(w: u32, h: u32, spp: u32, depth: Depth, seed: u64) -> Settings {
    Settings {
        width: w,
        height: h,
        spp,
        time: 0.0,
        depth,
        seed,
    }
}

/// `scene` rendered from `view`.
pub fn draw(scene: &Scene, view: &View, s: &Settings) -> Image {
    let rs = RayScene::build(scene, s.time);
    render_view(&rs, view, s, &|_| {}).expect("render")
}

/// Orthographic camera at `eye` looking at `target`, half height `ymag`.
pub fn ortho(eye: Vec3, target: Vec3, up: Vec3, ymag: f32) -> View {
    View::look_at(
        eye,
        target,
        up,
        Projection::Orthographic {
            xmag: ymag,
            ymag,
            znear: 0.0,
            zfar: 1.0,
        },
    )
}
