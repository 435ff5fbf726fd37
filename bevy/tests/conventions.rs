//! Where Bevy's conventions meet gibake's, checked rather than assumed
//! (no GPU): Bevy's perspective is gibake's reversed-Z infinite
//! projection, its orthographic one reversed Z too; a Bevy view becomes
//! gibake's camera (same matrix, eye, forward: both look down −Z with +Y
//! up, right-handed); Bevy's texture formats are ones gibake reads; the
//! lights the plugin spawns carry gibake's numbers in Bevy's units. The
//! GPU side of the same conventions (a depth and normal prepass rebuilt
//! into gibake's G-buffer, Bevy's sun against gibake's) is in `headless`.

use bevy::camera::CameraProjection;
use bevy::camera::{OrthographicProjection, PerspectiveProjection, ScalingMode};
use bevy::prelude::*;
use gibake_bevy::gibake_runtime::{CameraMatrices, LightKind};
use gibake_bevy::{BevyLight, bevy_light, camera_matrices};

fn close(a: Mat4, b: Mat4, eps: f32) -> bool {
    a.abs_diff_eq(b, eps)
}

#[test]
fn bevys_perspective_is_gibakes_reversed_z_infinite_projection() {
    for (fov, aspect, near) in [
        (75f32, 16.0 / 9.0, 0.05f32),
        (38.0, 1.0, 0.1),
        (90.0, 0.5, 2.0),
    ] {
        let p = PerspectiveProjection {
            fov: fov.to_radians(),
            aspect_ratio: aspect,
            near,
            ..Default::default()
        };
        let bevy = p.get_clip_from_view();
        let gibake =
            CameraMatrices::perspective(Mat4::IDENTITY, fov.to_radians(), aspect, near).view_proj;
        assert!(
            close(bevy, gibake, 1e-6),
            "{fov}°, {aspect}, {near}:\n{bevy}\n{gibake}"
        );
        // Reversed Z: the near plane at depth 1, far away towards 0.
        let depth = |z: f32| {
            let c = bevy * Vec4::new(0.0, 0.0, -z, 1.0);
            c.z / c.w
        };
        assert!((depth(near) - 1.0).abs() < 1e-6);
        assert!(depth(1.0e6 * near) < 1e-5 && depth(1.0e6 * near) > 0.0);
        // NDC y up: a point above the axis has y > 0 (row 0 at the top
        // of the image, as gibake's rebuild takes it).
        let c = bevy * Vec4::new(0.0, 1.0, -5.0, 1.0);
        assert!(c.y / c.w > 0.0);
    }
}

#[test]
fn bevys_orthographic_projection_is_reversed_z() {
    let mut p = OrthographicProjection {
        scaling_mode: ScalingMode::Fixed {
            width: 8.0,
            height: 4.0,
        },
        near: 0.5,
        far: 60.0,
        ..OrthographicProjection::default_3d()
    };
    p.update(800.0, 400.0);
    let bevy = p.get_clip_from_view();
    let gibake = CameraMatrices::orthographic(Mat4::IDENTITY, 2.0, 2.0, 0.5, 60.0);
    assert!(
        close(bevy, gibake.view_proj, 1e-6),
        "\n{bevy}\n{}",
        gibake.view_proj
    );
    let m = camera_matrices(&GlobalTransform::IDENTITY, bevy);
    assert!(m.orthographic);
}

#[test]
fn a_bevy_view_is_gibakes_camera() {
    let eye = Vec3::new(-2.93, 2.21, -1.89);
    let t = Transform::from_translation(eye).looking_at(Vec3::new(-0.1, 1.98, 2.23), Vec3::Y);
    let g = GlobalTransform::from(t);
    let clip = PerspectiveProjection {
        fov: 75f32.to_radians(),
        aspect_ratio: 5.0 / 3.0,
        near: 0.05,
        ..Default::default()
    }
    .get_clip_from_view();
    let ours = camera_matrices(&g, clip);
    let gibake = CameraMatrices::perspective(t.to_matrix(), 75f32.to_radians(), 5.0 / 3.0, 0.05);
    assert!(close(ours.view_proj, gibake.view_proj, 1e-5));
    assert!(ours.position.abs_diff_eq(gibake.position, 1e-6));
    assert!(ours.forward.abs_diff_eq(gibake.forward, 1e-6));
    // Both look down the camera's −Z: Bevy's forward.
    assert!(ours.forward.abs_diff_eq(*t.forward(), 1e-6));
    assert!(!ours.orthographic);
    // A world point in front of the camera lands inside the image.
    let c = ours.view_proj * Vec4::new(-0.1, 1.98, 2.23, 1.0);
    let ndc = c.truncate() / c.w;
    assert!(ndc.x.abs() < 1e-4 && ndc.y.abs() < 1e-4 && ndc.z > 0.0 && ndc.z < 1.0);
}

#[test]
fn bevys_gbuffer_formats_are_ones_gibake_reads() {
    use bevy::core_pipeline::core_3d::CORE_3D_DEPTH_FORMAT;
    use bevy::core_pipeline::deferred::DEFERRED_PREPASS_FORMAT;
    use bevy::core_pipeline::prepass::NORMAL_PREPASS_FORMAT;
    use bevy::render::render_resource::TextureFormat;
    // The prepass depth is what `DepthGBuffer::depth` takes.
    assert_eq!(CORE_3D_DEPTH_FORMAT, TextureFormat::Depth32Float);
    // A unorm normal target: `n · 0.5 + 0.5` (`NormalEncoding::WorldUnorm`;
    // the values themselves are checked on the GPU in `headless`).
    assert_eq!(NORMAL_PREPASS_FORMAT, TextureFormat::Rgb10a2Unorm);
    // The deferred G-buffer the plugin unpacks the albedo from.
    assert_eq!(DEFERRED_PREPASS_FORMAT, TextureFormat::Rgba32Uint);
    // The plugin's unpack shader is valid WGSL.
    let src = include_str!("../src/unpack_albedo.wgsl");
    if let Err(e) = gibake_gpu::shaders::validate(src) {
        panic!("unpack_albedo.wgsl does not validate:\n{e}");
    }
}

fn light(kind: LightKind, color: Vec3, direction: Vec3) -> gibake_bevy::gibake_runtime::Light {
    gibake_bevy::gibake_runtime::Light {
        name: "l".into(),
        kind,
        color,
        position: Vec3::new(1.0, 2.0, 3.0),
        direction,
        range: None,
    }
}

#[test]
fn the_lights_the_plugin_spawns_carry_gibakes_numbers_in_bevys_units() {
    let four_pi = 4.0 * std::f32::consts::PI;
    let lin = |c: Color| c.to_linear().to_vec3();
    // A sun of irradiance (3, 2.7, 2.4) W/m²: illuminance × colour.
    let d = Vec3::new(0.1, -0.86, 0.5).normalize();
    let (l, t) = bevy_light(&light(LightKind::Directional, Vec3::new(3.0, 2.7, 2.4), d));
    let BevyLight::Directional(s) = l else {
        panic!("{l:?}")
    };
    assert!((lin(s.color) * s.illuminance).abs_diff_eq(Vec3::new(3.0, 2.7, 2.4), 1e-5));
    assert!(
        t.forward().abs_diff_eq(d, 1e-5),
        "a Bevy light shines down its −Z"
    );
    assert!(s.shadow_maps_enabled);
    // A point light of 25 W/sr: Bevy's shader divides lumens by 4π.
    let (l, t) = bevy_light(&light(LightKind::Point, Vec3::splat(25.0), Vec3::NEG_Y));
    let BevyLight::Point(p) = l else {
        panic!("{l:?}")
    };
    assert!((lin(p.color) * p.intensity / four_pi).abs_diff_eq(Vec3::splat(25.0), 1e-4));
    assert!(t.translation.abs_diff_eq(Vec3::new(1.0, 2.0, 3.0), 1e-6));
    // A spot keeps glTF's cone.
    let (l, t) = bevy_light(&light(
        LightKind::Spot {
            inner_cone: 0.4,
            outer_cone: 0.6,
        },
        Vec3::new(40.0, 40.0, 20.0),
        Vec3::Y,
    ));
    let BevyLight::Spot(s) = l else {
        panic!("{l:?}")
    };
    assert_eq!((s.inner_angle, s.outer_angle), (0.4, 0.6));
    assert!((lin(s.color) * s.intensity / four_pi).abs_diff_eq(Vec3::new(40.0, 40.0, 20.0), 1e-3));
    assert!(
        t.forward().abs_diff_eq(Vec3::Y, 1e-5),
        "straight up needs another up vector"
    );
}
