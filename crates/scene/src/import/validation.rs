//! Parsing and validation where the `gltf` crate is stricter than glTF 2.0.
//!
//! gltf-json (1.4) refuses some files that the specification allows and the
//! Khronos validator accepts with no error; gibake parses and validates
//! them itself, so a valid level is never refused for these (the list, with
//! the validator's verdicts, is in docs/robustness.md, "glTF the `gltf`
//! crate refuses"):
//!
//! - [`parse`]: gltf-json's typed parse first; only where it fails is the
//!   JSON read again as a value and relaxed ([`Relaxed`]): a number with no
//!   fractional part is an integer (JSON has one number type; `"count":
//!   4.0` is 4), a scene without `nodes` has none, and an animation channel
//!   without a target node (one an extension such as
//!   `KHR_animation_pointer` targets) is marked, to be ignored. A file the
//!   typed parse reads is parsed exactly as before.
//! - [`validate`]: gltf-json's own checks (indices in range, POSITION
//!   bounds, camera and spot-light objects, byte strides, attribute names,
//!   ...), less the ones that are not glTF 2.0's errors: an accessor
//!   without `bufferView` (zeros, with any `sparse` substitution on top), a
//!   primitive without POSITION (skipped with a warning), enum values glTF
//!   does not define (the validator warns; an object holding one is
//!   refused or skipped only where gibake uses it), and the marked
//!   channels. Then the rules that go with accessors without `bufferView`
//!   and sparse accessors, which the validator calls errors and gltf-json
//!   does not check: `byteOffset` needs a `bufferView`; a sparse `count`
//!   is at least 1 and at most the accessor's; the buffer views of sparse
//!   indices and values have no `byteStride`. (The data rules of a sparse
//!   accessor — indices in range and strictly increasing, the views long
//!   enough — are checked when it is read, `accessors.rs`.)

use std::collections::HashSet;
use std::path::Path;

use gltf::json;
use gltf::json::validation::{Error as RuleError, Validate};
use serde_json::Value;

use crate::SceneError;

/// What [`parse`] relaxed to read the file.
#[derive(Debug, Default)]
pub(super) struct Relaxed {
    /// Animation channels `(animation, channel)` whose target names no
    /// node: their `node` is set to [`NO_NODE`], and the import ignores
    /// them.
    pub(super) nodeless_channels: HashSet<(usize, usize)>,
    /// Whether anything was changed at all.
    changed: bool,
}

/// The node index given to a channel without one (out of range for any
/// file: gltf-json's indices are `u32`, and the file's node count is far
/// smaller than this under every input budget).
const NO_NODE: u32 = u32::MAX;

/// Enum-valued fields of gltf-json (its `Checked` values): a value glTF
/// does not define is a warning of the Khronos validator
/// (`VALUE_NOT_IN_LIST`), not an error, so gltf-json's `Invalid` on these
/// is dropped; the importer decides where the object is used. (An invalid
/// attribute name, also `Checked` in gltf-json, stays an error, as it is
/// for the validator.)
const ENUM_FIELDS: &[&str] = &[
    "componentType",
    "type",
    "target",
    "mode",
    "alphaMode",
    "magFilter",
    "minFilter",
    "wrapS",
    "wrapT",
    "interpolation",
    "path",
];

/// Parses the glTF JSON (see the module docs): the typed parse, else the
/// relaxed one. When nothing could be relaxed, the typed parse's error
/// (with its line and column) stands.
pub(super) fn parse(bytes: &[u8]) -> Result<(json::Root, Relaxed), gltf::Error> {
    let first = match json::Root::from_slice(bytes) {
        Ok(root) => return Ok((root, Relaxed::default())),
        Err(e) => e,
    };
    let Ok(mut value) = serde_json::from_slice::<Value>(bytes) else {
        return Err(gltf::Error::Deserialize(first));
    };
    let relaxed = relax(&mut value);
    if !relaxed.changed {
        return Err(gltf::Error::Deserialize(first));
    }
    let root = serde_json::from_value(value).map_err(gltf::Error::Deserialize)?;
    Ok((root, relaxed))
}

/// Rewrites what glTF 2.0 allows and gltf-json's types do not.
fn relax(value: &mut Value) -> Relaxed {
    let mut relaxed = Relaxed::default();
    integral_numbers(value, &mut relaxed.changed);
    if let Some(scenes) = value.get_mut("scenes").and_then(Value::as_array_mut) {
        for scene in scenes.iter_mut().filter_map(Value::as_object_mut) {
            if !scene.contains_key("nodes") {
                scene.insert("nodes".into(), Value::Array(Vec::new()));
                relaxed.changed = true;
            }
        }
    }
    if let Some(anims) = value.get_mut("animations").and_then(Value::as_array_mut) {
        for (ai, anim) in anims.iter_mut().enumerate() {
            let Some(channels) = anim.get_mut("channels").and_then(Value::as_array_mut) else {
                continue;
            };
            for (ci, ch) in channels.iter_mut().enumerate() {
                let Some(target) = ch.get_mut("target").and_then(Value::as_object_mut) else {
                    continue;
                };
                if !target.contains_key("node") {
                    target.insert("node".into(), Value::from(NO_NODE));
                    relaxed.nodeless_channels.insert((ai, ci));
                    relaxed.changed = true;
                }
            }
        }
    }
    relaxed
}

/// Replaces every number with no fractional part (`4.0`, `1e2`) by the
/// integer it is, as JSON (and the validator, in JavaScript) reads it.
fn integral_numbers(value: &mut Value, changed: &mut bool) {
    match value {
        Value::Number(n) if !(n.is_u64() || n.is_i64()) => {
            // 2^53: every integer up to it is exact in an f64.
            const EXACT: f64 = 9_007_199_254_740_992.0;
            if let Some(x) = n.as_f64()
                && x.fract() == 0.0
                && x.abs() <= EXACT
            {
                *value = if x >= 0.0 {
                    Value::from(x as u64)
                } else {
                    Value::from(x as i64)
                };
                *changed = true;
            }
        }
        Value::Array(items) => {
            for v in items {
                integral_numbers(v, changed);
            }
        }
        Value::Object(map) => {
            for v in map.values_mut() {
                integral_numbers(v, changed);
            }
        }
        _ => {}
    }
}

/// gltf-json's validation less what glTF 2.0 allows, then the rules of
/// accessors without `bufferView` and of sparse accessors (module docs).
pub(super) fn validate(
    root: &json::Root,
    relaxed: &Relaxed,
    path: &Path,
) -> Result<(), SceneError> {
    let mut allowed: HashSet<String> = HashSet::new();
    let p = json::Path::new;
    for (i, a) in root.accessors.iter().enumerate() {
        if a.buffer_view.is_none() {
            allowed.insert(p().field("accessors").index(i).field("bufferView").0);
        }
    }
    for (mi, m) in root.meshes.iter().enumerate() {
        for pi in 0..m.primitives.len() {
            let prim = p().field("meshes").index(mi).field("primitives").index(pi);
            allowed.insert(prim.field("attributes").key("POSITION").0);
        }
    }
    for &(ai, ci) in &relaxed.nodeless_channels {
        let target = p()
            .field("animations")
            .index(ai)
            .field("channels")
            .index(ci);
        allowed.insert(target.field("target").field("node").0);
    }
    let mut errors = Vec::new();
    root.validate(root, json::Path::new, &mut |path, error| {
        let path = path();
        let tolerated = match error {
            RuleError::Missing | RuleError::IndexOutOfBounds => allowed.contains(path.as_str()),
            RuleError::Invalid => path
                .as_str()
                .rsplit('.')
                .next()
                .is_some_and(|last| ENUM_FIELDS.contains(&last)),
            RuleError::Oversize | RuleError::Unsupported => false,
        };
        if !tolerated {
            errors.push((path, error));
        }
    });
    if !errors.is_empty() {
        return Err(SceneError::Gltf {
            path: path.to_path_buf(),
            source: gltf::Error::Validation(errors),
        });
    }
    accessor_rules(root).map_err(|message| SceneError::Invalid {
        path: path.to_path_buf(),
        message,
    })
}

/// The validator's errors for accessors without `bufferView` and sparse
/// accessors that gltf-json does not check (module docs), on every
/// accessor of the file, used or not: they need no data.
fn accessor_rules(root: &json::Root) -> Result<(), String> {
    for (i, a) in root.accessors.iter().enumerate() {
        let label = match &a.name {
            Some(n) => format!("accessor {i} '{n}'"),
            None => format!("accessor {i}"),
        };
        if a.buffer_view.is_none()
            && let Some(off) = a.byte_offset
        {
            return Err(format!(
                "{label}: byteOffset {} without a bufferView (glTF 2.0 allows byteOffset only with one)",
                off.0
            ));
        }
        let Some(sparse) = &a.sparse else { continue };
        let count = a.count.0;
        let sc = sparse.count.0;
        if sc == 0 {
            return Err(format!(
                "{label}: sparse count is 0; glTF 2.0 requires at least 1"
            ));
        }
        if sc > count {
            return Err(format!(
                "{label}: sparse count {sc} exceeds the accessor's count {count}"
            ));
        }
        for (what, view) in [
            ("indices", sparse.indices.buffer_view.value()),
            ("values", sparse.values.buffer_view.value()),
        ] {
            // gltf-json has checked the index.
            if let Some(stride) = root.buffer_views.get(view).and_then(|v| v.byte_stride) {
                return Err(format!(
                    "{label}: the bufferView {view} of its sparse {what} has byteStride {}; glTF 2.0 forbids one there",
                    stride.0
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integral_floats_become_integers_and_nothing_else_changes() {
        let mut v: Value = serde_json::from_str(
            r#"{"a": 4.0, "b": [1e2, -3.0, 0.5, -0.0], "c": {"d": 1e300, "e": 7, "f": "4.0"}}"#,
        )
        .unwrap();
        let mut changed = false;
        integral_numbers(&mut v, &mut changed);
        assert!(changed);
        assert_eq!(
            v,
            serde_json::json!({"a": 4, "b": [100, -3, 0.5, 0], "c": {"d": 1e300, "e": 7, "f": "4.0"}})
        );
        assert!(v["a"].is_u64() && v["b"][1].is_i64() && v["c"]["d"].is_f64());
        let mut plain: Value = serde_json::from_str(r#"{"a": [1, 2.5]}"#).unwrap();
        let mut changed = false;
        integral_numbers(&mut plain, &mut changed);
        assert!(!changed);
    }

    #[test]
    fn a_parse_error_that_nothing_relaxes_keeps_its_position() {
        let e = parse(br#"{"asset": {"version": "2.0"}, "accessors": [{"count": "x"}]}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 1 column"), "{e}");
    }
}
