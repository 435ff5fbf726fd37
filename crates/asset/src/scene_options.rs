//! [`SceneOptions`]: what a bake applied to the level as exported that is
//! part of its static scene — the command line's `--sun` (with
//! `--sun-irradiance`, `--sun-color`), `--dynamic`, `--light`,
//! `--bake-volume` and `--max-texture-size` — recorded in the manifest
//! (format 4.4, [`crate::Manifest::scene_options`]) so that whatever uses
//! the asset with the level can load it the same way.
//!
//! [`SceneOptions::resolve`] is the one rule every user applies (`gibake
//! render`, `gibake view`, the runtime's `load_scene_for`): an option not
//! given is taken from the record; one given must equal it, else
//! [`OptionsConflict`]. Two renderings: [`SceneOptions::flags`], the bake's
//! command-line flags (what the tools print), and `Display`, plain words
//! (what the runtime's messages say: they quote no command line).

use std::fmt;

use serde::{Deserialize, Serialize};

/// The importer's largest texture side when `--max-texture-size` is not
/// given (`gibake_scene::Limits::default`): not recorded.
pub const DEFAULT_MAX_TEXTURE_SIZE: u32 = 8192;

/// A directional light added to the level (`--sun AZIMUTH,ELEVATION`,
/// `--sun-irradiance`, `--sun-color`); mirrors `gibake_scene::Sun`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SunOption {
    /// Degrees, clockwise seen from above (+Y) from −Z.
    pub azimuth_deg: f32,
    /// Degrees above the horizon, in (0, 90].
    pub elevation_deg: f32,
    /// Irradiance on a surface facing it, W/m² (default 1).
    pub irradiance: f32,
    /// Linear RGB colour multiplying the irradiance (default 1, 1, 1).
    pub color: [f32; 3],
}

/// The scene options a bake applied that are part of the static-scene
/// hash. Empty ([`SceneOptions::is_empty`]): the level as exported, none
/// given. Encoded in the manifest payload (format 4.4) field by field in
/// this order (docs/asset-format.md).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SceneOptions {
    /// `--sun`: a directional light replacing the file's lights.
    pub sun: Option<SunOption>,
    /// `--dynamic` patterns (globs on node names) marking moving objects;
    /// sorted, no duplicates ([`SceneOptions::normalized`]).
    pub dynamic: Vec<String>,
    /// `--light` names: only these of the file's lights; empty: every
    /// light. Sorted, no duplicates.
    pub lights: Vec<String>,
    /// `--bake-volume` (min x, y, z, max x, y, z, world space).
    pub bake_volume: Option<[f32; 6]>,
    /// `--max-texture-size`, when not the default
    /// [`DEFAULT_MAX_TEXTURE_SIZE`] (larger textures are downscaled, which
    /// changes the static scene).
    pub max_texture_size: Option<u32>,
}

/// One kind of option of [`SceneOptions`] (a flag with its companions).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum SceneOption {
    /// `--sun` (with `--sun-irradiance`, `--sun-color`).
    Sun,
    /// `--dynamic`.
    Dynamic,
    /// `--light`.
    Lights,
    /// `--bake-volume`.
    BakeVolume,
    /// `--max-texture-size`.
    MaxTextureSize,
}

impl SceneOption {
    /// Every kind, in the order of [`SceneOptions`]' fields.
    pub const ALL: [SceneOption; 5] = [
        SceneOption::Sun,
        SceneOption::Dynamic,
        SceneOption::Lights,
        SceneOption::BakeVolume,
        SceneOption::MaxTextureSize,
    ];

    /// The command-line flag (`--sun`, ...).
    pub fn flag(self) -> &'static str {
        match self {
            SceneOption::Sun => "--sun",
            SceneOption::Dynamic => "--dynamic",
            SceneOption::Lights => "--light",
            SceneOption::BakeVolume => "--bake-volume",
            SceneOption::MaxTextureSize => "--max-texture-size",
        }
    }

    /// Plain words (`sun`, `moving objects`, ...).
    pub fn name(self) -> &'static str {
        match self {
            SceneOption::Sun => "sun",
            SceneOption::Dynamic => "moving objects",
            SceneOption::Lights => "lights",
            SceneOption::BakeVolume => "bake volume",
            SceneOption::MaxTextureSize => "largest texture side",
        }
    }
}

/// Every flag of [`SceneOption::ALL`], for messages: `--sun, --dynamic, …`.
pub fn all_flags() -> String {
    let f: Vec<&str> = SceneOption::ALL.iter().map(|o| o.flag()).collect();
    format!("{} or {}", f[..f.len() - 1].join(", "), f[f.len() - 1])
}

/// What [`SceneOptions::resolve`] decided.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Resolution {
    /// The options to load the level with: the given ones, and the
    /// recorded ones of every kind not given.
    pub options: SceneOptions,
    /// The recorded options taken because none of their kind was given
    /// (empty: nothing was taken; say so when it is not).
    pub applied: SceneOptions,
}

/// Options given that differ from the ones the asset was baked with.
/// `Display`: plain words; [`OptionsConflict::flags_message`]: a tool's.
#[derive(Clone, Debug, PartialEq)]
pub struct OptionsConflict {
    /// What the asset records (boxed: errors stay small).
    pub recorded: Box<SceneOptions>,
    /// What was given.
    pub given: Box<SceneOptions>,
    /// The kinds given that differ from the record.
    pub differ: Vec<SceneOption>,
}

impl OptionsConflict {
    /// The message a command-line tool gives: `asset` was baked with the
    /// recorded flags, `command` was given others, and what to do.
    pub fn flags_message(&self, asset: &str, command: &str) -> String {
        let differ: Vec<&str> = self.differ.iter().map(|o| o.flag()).collect();
        format!(
            "{asset} was baked with {}, but `{command}` was given {} ({} differ{}): these flags change the static scene the asset was baked from; give `{command}` the same ones, or none of them (the bake's are then applied), or re-bake with the new ones",
            self.recorded.flags_or_none(),
            self.given.flags_or_none(),
            differ.join(", "),
            if differ.len() == 1 { "s" } else { "" }
        )
    }
}

impl fmt::Display for OptionsConflict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let differ: Vec<&str> = self.differ.iter().map(|o| o.name()).collect();
        write!(
            f,
            "the scene options given ({}) differ from the ones the asset was baked with ({}) in: {}; load the scene with the asset's options, or re-bake it",
            self.given,
            self.recorded,
            differ.join(", ")
        )
    }
}

impl std::error::Error for OptionsConflict {}

/// `x` as the shortest decimal that reads back as the same `f32`.
fn num(x: f32) -> String {
    format!("{x}")
}

/// Comma-separated numbers.
fn nums(v: &[f32]) -> String {
    v.iter().map(|x| num(*x)).collect::<Vec<_>>().join(",")
}

/// `word` as one shell word: itself when it holds only characters no
/// shell treats specially, else in single quotes (`'` written `'\''`).
pub fn shell_word(word: &str) -> String {
    let plain = !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-.,/:=+@%".contains(c));
    if plain {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', r"'\''"))
    }
}

/// `--flag value`, or `--flag=value` when the value starts with `-` (so
/// that no parser takes it for a flag).
fn flag_value(flag: &str, value: String) -> String {
    if value.starts_with('-') {
        format!("{flag}={value}")
    } else {
        format!("{flag} {value}")
    }
}

fn same_f32(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

impl SunOption {
    /// Bit-for-bit the same sun (what the static-scene hash sees).
    pub fn same(&self, o: &SunOption) -> bool {
        same_f32(
            &[self.azimuth_deg, self.elevation_deg, self.irradiance],
            &[o.azimuth_deg, o.elevation_deg, o.irradiance],
        ) && same_f32(&self.color, &o.color)
    }

    /// What is wrong with it, if anything (the rules of `--sun`).
    pub fn problem(&self) -> Option<String> {
        if !self.azimuth_deg.is_finite() {
            return Some(format!("sun azimuth {} is not finite", self.azimuth_deg));
        }
        if !(self.elevation_deg > 0.0 && self.elevation_deg <= 90.0) {
            return Some(format!(
                "sun elevation {} is not in (0, 90] degrees",
                self.elevation_deg
            ));
        }
        if !(self.irradiance.is_finite() && self.irradiance >= 0.0) {
            return Some(format!(
                "sun irradiance {} is not finite and non-negative",
                self.irradiance
            ));
        }
        if !self.color.iter().all(|c| c.is_finite() && *c >= 0.0) {
            return Some(format!(
                "sun colour {} is not finite and non-negative",
                nums(&self.color)
            ));
        }
        None
    }
}

impl SceneOptions {
    /// No option: the level as exported.
    pub fn is_empty(&self) -> bool {
        *self == SceneOptions::default()
    }

    /// Whether any option of kind `o` is given.
    pub fn has(&self, o: SceneOption) -> bool {
        match o {
            SceneOption::Sun => self.sun.is_some(),
            SceneOption::Dynamic => !self.dynamic.is_empty(),
            SceneOption::Lights => !self.lights.is_empty(),
            SceneOption::BakeVolume => self.bake_volume.is_some(),
            SceneOption::MaxTextureSize => self.max_texture_size.is_some(),
        }
    }

    /// The options of kind `o` taken from `from` (replacing these).
    fn take(&mut self, o: SceneOption, from: &SceneOptions) {
        match o {
            SceneOption::Sun => self.sun = from.sun,
            SceneOption::Dynamic => self.dynamic = from.dynamic.clone(),
            SceneOption::Lights => self.lights = from.lights.clone(),
            SceneOption::BakeVolume => self.bake_volume = from.bake_volume,
            SceneOption::MaxTextureSize => self.max_texture_size = from.max_texture_size,
        }
    }

    /// Whether the options of kind `o` are the same here and in `other`
    /// (floats bit for bit; both normalized).
    fn same_kind(&self, o: SceneOption, other: &SceneOptions) -> bool {
        match o {
            SceneOption::Sun => match (&self.sun, &other.sun) {
                (Some(a), Some(b)) => a.same(b),
                (a, b) => a.is_none() && b.is_none(),
            },
            SceneOption::Dynamic => self.dynamic == other.dynamic,
            SceneOption::Lights => self.lights == other.lights,
            SceneOption::BakeVolume => match (&self.bake_volume, &other.bake_volume) {
                (Some(a), Some(b)) => same_f32(a, b),
                (a, b) => a.is_none() && b.is_none(),
            },
            SceneOption::MaxTextureSize => self.max_texture_size == other.max_texture_size,
        }
    }

    /// Whether these options load the same scene as `other` (after
    /// normalizing both; floats bit for bit).
    pub fn same(&self, other: &SceneOptions) -> bool {
        let (a, b) = (self.normalized(), other.normalized());
        SceneOption::ALL.iter().all(|o| a.same_kind(*o, &b))
    }

    /// The canonical form a bake records: `dynamic` and `lights` sorted
    /// (byte order) without duplicates (their order never matters), and no
    /// `max_texture_size` when it is the default.
    pub fn normalized(&self) -> SceneOptions {
        let sorted = |v: &[String]| {
            let mut v = v.to_vec();
            v.sort();
            v.dedup();
            v
        };
        SceneOptions {
            sun: self.sun,
            dynamic: sorted(&self.dynamic),
            lights: sorted(&self.lights),
            bake_volume: self.bake_volume,
            max_texture_size: self
                .max_texture_size
                .filter(|&n| n != DEFAULT_MAX_TEXTURE_SIZE),
        }
    }

    /// What is wrong with the values, if anything (what a valid manifest
    /// holds: the rules of the flags).
    pub fn problem(&self) -> Option<String> {
        if let Some(p) = self.sun.as_ref().and_then(SunOption::problem) {
            return Some(p);
        }
        if let Some(v) = &self.bake_volume
            && (!v.iter().all(|x| x.is_finite()) || (0..3).any(|k| v[k] >= v[k + 3]))
        {
            return Some(format!(
                "bake volume {} is not a finite box with each minimum below its maximum",
                nums(v)
            ));
        }
        if let Some(n) = self.max_texture_size
            && !(1..=65536).contains(&n)
        {
            return Some(format!("largest texture side {n} is not in 1..=65536"));
        }
        None
    }

    /// The options `given` (e.g. on a command line) resolved against the
    /// ones an asset `recorded` (`None`: it records none, format 4.3 or
    /// older; then `given` is used as it is). Per kind of option: not given
    /// → the recorded one is taken (and listed in
    /// [`Resolution::applied`]); given and the same → kept; given and
    /// different → an [`OptionsConflict`] listing every such kind. Each of
    /// these options changes the static scene, so a different one would
    /// load another scene than the one baked.
    pub fn resolve(
        recorded: Option<&SceneOptions>,
        given: &SceneOptions,
    ) -> Result<Resolution, OptionsConflict> {
        let given = given.normalized();
        let Some(recorded) = recorded else {
            return Ok(Resolution {
                options: given,
                applied: SceneOptions::default(),
            });
        };
        let recorded = recorded.normalized();
        let mut options = given.clone();
        let mut applied = SceneOptions::default();
        let mut differ = Vec::new();
        for o in SceneOption::ALL {
            if !given.has(o) {
                options.take(o, &recorded);
                applied.take(o, &recorded);
            } else if !given.same_kind(o, &recorded) {
                differ.push(o);
            }
        }
        if differ.is_empty() {
            Ok(Resolution { options, applied })
        } else {
            Err(OptionsConflict {
                recorded: Box::new(recorded),
                given: Box::new(given),
                differ,
            })
        }
    }

    /// The command-line flags that give these options, shell-quoted where
    /// needed: `--sun 173,60 --dynamic 'Cylinder*'` (empty for none).
    pub fn flags(&self) -> String {
        let mut out: Vec<String> = Vec::new();
        if let Some(s) = &self.sun {
            out.push(flag_value(
                "--sun",
                format!("{},{}", num(s.azimuth_deg), num(s.elevation_deg)),
            ));
            if s.irradiance.to_bits() != 1f32.to_bits() {
                out.push(flag_value("--sun-irradiance", num(s.irradiance)));
            }
            if !same_f32(&s.color, &[1.0; 3]) {
                out.push(flag_value("--sun-color", nums(&s.color)));
            }
        }
        for p in &self.dynamic {
            out.push(format!("--dynamic {}", shell_word(p)));
        }
        for l in &self.lights {
            out.push(format!("--light {}", shell_word(l)));
        }
        if let Some(v) = &self.bake_volume {
            out.push(flag_value("--bake-volume", nums(v)));
        }
        if let Some(n) = self.max_texture_size {
            out.push(format!("--max-texture-size {n}"));
        }
        out.join(" ")
    }

    /// [`SceneOptions::flags`], or `none of --sun, …` when there are none.
    pub fn flags_or_none(&self) -> String {
        if self.is_empty() {
            format!("none of {}", all_flags())
        } else {
            self.flags()
        }
    }
}

/// Plain words, no command line: `sun at azimuth 173°, elevation 60°;
/// moving objects 'Cylinder*'` (`none` for none).
impl fmt::Display for SceneOptions {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts: Vec<String> = Vec::new();
        if let Some(s) = &self.sun {
            parts.push(format!(
                "sun at azimuth {}°, elevation {}°, irradiance {} W/m², colour {}",
                num(s.azimuth_deg),
                num(s.elevation_deg),
                num(s.irradiance),
                nums(&s.color)
            ));
        }
        let quoted = |v: &[String]| {
            v.iter()
                .map(|s| format!("'{}'", s.escape_debug()))
                .collect::<Vec<_>>()
                .join(", ")
        };
        if !self.dynamic.is_empty() {
            parts.push(format!("moving objects {}", quoted(&self.dynamic)));
        }
        if !self.lights.is_empty() {
            parts.push(format!("only the lights {}", quoted(&self.lights)));
        }
        if let Some(v) = &self.bake_volume {
            parts.push(format!(
                "bake volume from ({}) to ({})",
                nums(&v[..3]),
                nums(&v[3..])
            ));
        }
        if let Some(n) = self.max_texture_size {
            parts.push(format!("textures at most {n} texels on a side"));
        }
        if parts.is_empty() {
            write!(f, "none")
        } else {
            write!(f, "{}", parts.join("; "))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sun(az: f32, el: f32) -> SunOption {
        SunOption {
            azimuth_deg: az,
            elevation_deg: el,
            irradiance: 1.0,
            color: [1.0; 3],
        }
    }

    fn room() -> SceneOptions {
        SceneOptions {
            sun: Some(sun(173.0, 60.0)),
            dynamic: vec!["Cylinder*".into()],
            ..Default::default()
        }
    }

    #[test]
    fn flags_read_as_a_command_line() {
        assert_eq!(room().flags(), "--sun 173,60 --dynamic 'Cylinder*'");
        let o = SceneOptions {
            sun: Some(SunOption {
                irradiance: 2.5,
                color: [1.0, 0.9, 0.8],
                ..sun(-10.0, 45.5)
            }),
            lights: vec!["spot_lamp".into(), "it's".into()],
            bake_volume: Some([-1.0, 0.0, -1.0, 1.0, 2.0, 1.0]),
            max_texture_size: Some(1024),
            ..Default::default()
        };
        assert_eq!(
            o.flags(),
            "--sun=-10,45.5 --sun-irradiance 2.5 --sun-color 1,0.9,0.8 --light spot_lamp \
             --light 'it'\\''s' --bake-volume=-1,0,-1,1,2,1 --max-texture-size 1024"
        );
        assert_eq!(SceneOptions::default().flags(), "");
        assert!(
            SceneOptions::default()
                .flags_or_none()
                .starts_with("none of --sun, --dynamic, --light")
        );
        // Plain words quote no flag.
        let words = o.to_string();
        assert!(!words.contains("--"), "{words}");
        assert!(words.contains("azimuth -10°") && words.contains("'spot_lamp'"));
        assert_eq!(SceneOptions::default().to_string(), "none");
    }

    #[test]
    fn resolve_takes_what_is_not_given_and_refuses_what_differs() {
        let r = room();
        // Nothing given: the record, all of it applied.
        let got = SceneOptions::resolve(Some(&r), &SceneOptions::default()).unwrap();
        assert_eq!(got.options, r);
        assert_eq!(got.applied, r);
        // The same given: nothing applied.
        let got = SceneOptions::resolve(Some(&r), &r).unwrap();
        assert_eq!(got.options, r);
        assert!(got.applied.is_empty());
        // Part given: the rest applied.
        let part = SceneOptions {
            sun: r.sun,
            ..Default::default()
        };
        let got = SceneOptions::resolve(Some(&r), &part).unwrap();
        assert_eq!(got.options, r);
        assert_eq!(got.applied.dynamic, r.dynamic);
        assert!(got.applied.sun.is_none());
        // Another sun: refused, naming it.
        let other = SceneOptions {
            sun: Some(sun(10.0, 60.0)),
            ..Default::default()
        };
        let e = SceneOptions::resolve(Some(&r), &other).unwrap_err();
        assert_eq!(e.differ, vec![SceneOption::Sun]);
        let msg = e.flags_message("room.gibake", "render");
        assert!(
            msg.contains("room.gibake was baked with --sun 173,60 --dynamic 'Cylinder*'")
                && msg.contains("was given --sun 10,60 (--sun differs)"),
            "{msg}"
        );
        assert!(!e.to_string().contains("--"), "{e}");
        // A flag the bake did not have: refused.
        let lights = SceneOptions {
            lights: vec!["a".into()],
            ..Default::default()
        };
        let e = SceneOptions::resolve(Some(&SceneOptions::default()), &lights).unwrap_err();
        assert_eq!(e.differ, vec![SceneOption::Lights]);
        assert!(
            e.flags_message("x", "view")
                .contains("baked with none of --sun")
        );
        // Nothing recorded (an older asset): the given ones as they are.
        let got = SceneOptions::resolve(None, &other).unwrap();
        assert_eq!(got.options, other);
        assert!(got.applied.is_empty());
    }

    #[test]
    fn order_duplicates_and_the_default_texture_size_do_not_matter() {
        let a = SceneOptions {
            dynamic: vec!["b*".into(), "a*".into(), "b*".into()],
            lights: vec!["y".into(), "x".into()],
            max_texture_size: Some(DEFAULT_MAX_TEXTURE_SIZE),
            ..Default::default()
        };
        let n = a.normalized();
        assert_eq!(n.dynamic, vec!["a*", "b*"]);
        assert_eq!(n.lights, vec!["x", "y"]);
        assert_eq!(n.max_texture_size, None);
        assert!(a.same(&n));
        assert!(
            SceneOptions::resolve(Some(&n), &a)
                .unwrap()
                .applied
                .is_empty()
        );
        assert!(!a.same(&SceneOptions::default()));
    }

    #[test]
    fn problems_are_named() {
        let bad = |o: SceneOptions| o.problem().expect("a problem");
        assert!(
            bad(SceneOptions {
                sun: Some(sun(0.0, 0.0)),
                ..Default::default()
            })
            .contains("elevation 0")
        );
        assert!(
            bad(SceneOptions {
                bake_volume: Some([0.0, 0.0, 0.0, 1.0, 0.0, 1.0]),
                ..Default::default()
            })
            .contains("bake volume")
        );
        assert!(
            bad(SceneOptions {
                max_texture_size: Some(0),
                ..Default::default()
            })
            .contains("texture side 0")
        );
        assert_eq!(room().problem(), None);
    }
}
