//! What a user adds to a level as exported, without editing the file: a sun
//! for a level exported without a light (`--sun`), a camera (`--camera`,
//! `--look-at`) and moving objects marked by node name (`--dynamic`).
//!
//! These are plain data carried by [`crate::LoadOptions`]; the importer
//! applies them (a sun is the primary light and so part of the static-scene
//! hash; the camera is not part of it; a node marked dynamic leaves the
//! static scene, which changes the hash as it should).

use glam::{Mat4, Vec3};

/// A directional primary light given on the command line (`--sun`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sun {
    /// Degrees, clockwise seen from above (+Y), from the −Z axis: 0 puts the
    /// sun toward −Z, 90 toward +X, 180 toward +Z, 270 toward −X.
    pub azimuth_deg: f32,
    /// Degrees above the horizon (the XZ plane), in (0, 90].
    pub elevation_deg: f32,
    /// Irradiance on a surface facing the sun, W/m² (`color ×
    /// intensity` of a glTF directional light).
    pub irradiance: f32,
    /// Linear RGB colour, multiplied by `irradiance`.
    pub color: Vec3,
}

impl Sun {
    /// A white sun of 1 W/m² at the given angles.
    pub fn new(azimuth_deg: f32, elevation_deg: f32) -> Sun {
        Sun {
            azimuth_deg,
            elevation_deg,
            irradiance: 1.0,
            color: Vec3::ONE,
        }
    }

    /// Unit vector from the scene toward the sun.
    pub fn toward(&self) -> Vec3 {
        let (az, el) = (
            f64::from(self.azimuth_deg).to_radians(),
            f64::from(self.elevation_deg).to_radians(),
        );
        glam::DVec3::new(el.cos() * az.sin(), el.sin(), -el.cos() * az.cos())
            .normalize()
            .as_vec3()
    }

    /// Checks the angles and the colour; the message names the flag.
    pub fn validate(&self) -> Result<(), String> {
        if !self.azimuth_deg.is_finite() {
            return Err(format!(
                "--sun azimuth {} is not a finite number of degrees",
                self.azimuth_deg
            ));
        }
        if !(self.elevation_deg > 0.0 && self.elevation_deg <= 90.0) {
            return Err(format!(
                "--sun elevation {} must be in (0, 90] degrees above the horizon",
                self.elevation_deg
            ));
        }
        if !(self.irradiance.is_finite() && self.irradiance >= 0.0) {
            return Err(format!(
                "--sun-irradiance {} must be finite and non-negative (W/m²)",
                self.irradiance
            ));
        }
        if !(self.color.is_finite() && self.color.min_element() >= 0.0) {
            return Err(format!(
                "--sun-color {} must be finite and non-negative",
                self.color
            ));
        }
        Ok(())
    }
}

/// Which camera renders the scene.
#[derive(Clone, Debug, PartialEq, Default)]
pub enum CameraChoice {
    /// The first camera node of the scene (the default).
    #[default]
    First,
    /// The camera (glTF camera name, else node name) of this name.
    Named(String),
    /// A perspective camera at `eye` looking at `target` (world space, +Y
    /// up), vertical field of view `yfov_deg` degrees.
    LookAt {
        /// Camera position.
        eye: Vec3,
        /// The point it looks at.
        target: Vec3,
        /// Vertical field of view, degrees.
        yfov_deg: f32,
    },
}

impl CameraChoice {
    /// The world matrix of a look-at camera (glTF: the camera looks down its
    /// −Z, +Y up), or a message saying what is wrong with it.
    pub fn look_at_matrix(eye: Vec3, target: Vec3) -> Result<Mat4, String> {
        let f = target - eye;
        if !(eye.is_finite() && target.is_finite()) {
            return Err("--look-at needs finite coordinates".into());
        }
        let Some(f) = f.try_normalize() else {
            return Err("--look-at: EYE and TARGET are the same point".into());
        };
        // Up is +Y unless the view is (nearly) vertical, then −Z.
        let up = if f.y.abs() > 0.999 {
            Vec3::NEG_Z
        } else {
            Vec3::Y
        };
        // Columns: right (+X), up (+Y), back (+Z = −forward), position.
        let right = f.cross(up).normalize();
        let true_up = right.cross(f);
        Ok(Mat4::from_cols(
            right.extend(0.0),
            true_up.extend(0.0),
            (-f).extend(0.0),
            eye.extend(1.0),
        ))
    }
}

/// Whether `name` matches the glob `pattern`: `*` any run of characters
/// (also empty), `?` exactly one, everything else itself
/// (case-sensitive, as glTF names are).
pub fn glob_match(pattern: &str, name: &str) -> bool {
    let p: Vec<char> = pattern.chars().collect();
    let s: Vec<char> = name.chars().collect();
    // Iterative matcher with one backtrack point (the last `*`): linear in
    // practice, O(|p|·|s|) at worst; never recursive.
    let (mut i, mut j) = (0usize, 0usize);
    let mut star: Option<(usize, usize)> = None;
    while j < s.len() {
        if i < p.len() && (p[i] == '?' || p[i] == s[j]) {
            i += 1;
            j += 1;
        } else if i < p.len() && p[i] == '*' {
            star = Some((i, j));
            i += 1;
        } else if let Some((si, sj)) = star {
            i = si + 1;
            j = sj + 1;
            star = Some((si, sj + 1));
        } else {
            return false;
        }
    }
    while i < p.len() && p[i] == '*' {
        i += 1;
    }
    i == p.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn globs() {
        assert!(glob_match("*", ""));
        assert!(glob_match("Ball*", "Ball.003"));
        assert!(glob_match("*car*", "the car body"));
        assert!(glob_match("door_?", "door_1"));
        assert!(!glob_match("door_?", "door_12"));
        assert!(!glob_match("Ball*", "ball"));
        assert!(glob_match("a*b*c", "a_x_b_y_c"));
        assert!(!glob_match("a*b*c", "a_x_b_y"));
        assert!(glob_match("Lamp", "Lamp"));
        assert!(!glob_match("Lamp", "Lamp2"));
    }

    #[test]
    fn sun_directions() {
        let up = Sun::new(0.0, 90.0).toward();
        assert!((up - Vec3::Y).length() < 1e-6);
        let s = Sun::new(90.0, 45.0).toward();
        assert!(s.x > 0.7 && s.y > 0.7 && s.z.abs() < 1e-6);
        let n = Sun::new(0.0, 10.0).toward();
        assert!(n.z < -0.9);
        assert!(Sun::new(0.0, 0.0).validate().is_err());
        assert!(Sun::new(f32::NAN, 30.0).validate().is_err());
        assert!(Sun::new(10.0, 30.0).validate().is_ok());
    }

    #[test]
    fn look_at_points_minus_z_at_the_target() {
        let m = CameraChoice::look_at_matrix(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO).unwrap();
        let fwd = m.transform_vector3(Vec3::NEG_Z).normalize();
        let want = (Vec3::ZERO - Vec3::new(1.0, 2.0, 3.0)).normalize();
        assert!((fwd - want).length() < 1e-5);
        assert!(
            m.transform_point3(Vec3::ZERO)
                .distance(Vec3::new(1.0, 2.0, 3.0))
                < 1e-5
        );
        // Straight down works too.
        assert!(CameraChoice::look_at_matrix(Vec3::Y, Vec3::ZERO).is_ok());
        assert!(CameraChoice::look_at_matrix(Vec3::Y, Vec3::Y).is_err());
    }
}
