//! Resource limits on the command line: the import budgets of every command
//! that reads a scene ([`LimitArgs`], flattened into the scene arguments),
//! the global `--max-memory` budget (bake estimate, asset decoding) and the
//! parsers of byte sizes and `diff` tolerances. The limits themselves, and
//! why each exists, are listed in docs/robustness.md.

use clap::Args;

/// Import budgets (see `gibake_scene::limits`).
#[derive(Args, Debug, Clone)]
pub struct LimitArgs {
    /// Largest input file read (scene, external buffer or image), in bytes
    /// (suffixes K, M, G, T; powers of 1024).
    #[arg(long, value_name = "BYTES", value_parser = parse_size, default_value = "2G")]
    pub max_input_bytes: u64,
    /// Most accessor elements read from the scene, in total (sparse included).
    #[arg(long, value_name = "N", default_value_t = 1 << 24)]
    pub max_elements: u64,
    /// Most texels decoded from the scene's images, in total (checked on the
    /// image headers before decoding).
    #[arg(long, value_name = "N", default_value_t = 1 << 26)]
    pub max_texels: u64,
    /// Largest texture side kept; larger textures are downscaled with a
    /// warning (the GPU's own limit applies on top). A downscaled texture
    /// changes the static scene: `bake` records a value other than the
    /// default, and `render` and `view` apply it when given the default.
    #[arg(long, value_name = "N", default_value_t = 8192,
          value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub max_texture_size: u32,
    /// Most animation keyframes × moving objects (the work of sampling the
    /// moving objects' swept bounds).
    #[arg(long, value_name = "N", default_value_t = 1 << 26)]
    pub max_animation_work: u64,
    /// Let external buffer and image URIs point outside the scene's directory.
    #[arg(long)]
    pub allow_outside_uris: bool,
    /// Most primary lights a scene may have (each costs maps and passes); a
    /// file with more is refused (pick some with --light NAME).
    #[arg(long, value_name = "N", default_value_t = 256,
          value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub max_lights: u32,
}

impl LimitArgs {
    /// The scene crate's limits.
    pub fn to_limits(&self) -> gibake_scene::Limits {
        gibake_scene::Limits {
            max_input_bytes: self.max_input_bytes,
            max_elements: self.max_elements,
            max_texels: self.max_texels,
            max_texture_size: self.max_texture_size,
            max_animation_work: self.max_animation_work,
            allow_outside_uris: self.allow_outside_uris,
            max_lights: self.max_lights,
        }
    }
}

/// Parses a byte size: a whole number with an optional K, M, G or T suffix
/// (powers of 1024, an optional trailing `B` or `iB`).
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let upper = t.to_ascii_uppercase();
    let body = upper
        .strip_suffix("IB")
        .or_else(|| upper.strip_suffix('B'))
        .unwrap_or(&upper);
    let (digits, shift) = match body.chars().last() {
        Some('K') => (&body[..body.len() - 1], 10),
        Some('M') => (&body[..body.len() - 1], 20),
        Some('G') => (&body[..body.len() - 1], 30),
        Some('T') => (&body[..body.len() - 1], 40),
        _ => (body, 0),
    };
    let n: u64 = digits
        .trim()
        .parse()
        .map_err(|_| format!("'{text}' is not a size (e.g. 512M, 4G, 1048576)"))?;
    n.checked_mul(1u64 << shift)
        .filter(|&v| v > 0)
        .ok_or_else(|| format!("'{text}' is out of range (1 byte to 16 EiB)"))
}

/// Available memory as the kernel estimates it (`MemAvailable`), if known.
fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// The default of `--max-memory`: 2 GiB, or half the available memory when
/// that is less.
pub fn default_memory_budget() -> u64 {
    let cap = 2u64 << 30;
    available_memory().map_or(cap, |a| cap.min(a / 2))
}

static MEMORY: std::sync::OnceLock<u64> = std::sync::OnceLock::new();

/// Records the global `--max-memory` flag (once, at start).
pub fn set_memory_budget(flag: Option<u64>) {
    let _ = MEMORY.set(memory_budget(flag));
}

/// The memory budget of this run (`--max-memory` or its default).
pub fn memory() -> u64 {
    *MEMORY.get_or_init(default_memory_budget)
}

/// Loads an asset, refusing one whose maps decode to more than [`memory`].
pub fn load_asset(dir: &std::path::Path) -> Result<gibake_asset::Asset, gibake_asset::AssetError> {
    gibake_asset::load_with_limit(dir, memory())
}

/// `--max-memory` if given, else [`default_memory_budget`].
pub fn memory_budget(flag: Option<u64>) -> u64 {
    flag.unwrap_or_else(default_memory_budget)
}

/// Clap parser of a `diff` tolerance flag: a finite number in [0, 1].
pub fn tolerance_f32(flag: &'static str) -> impl Fn(&str) -> Result<f32, String> + Clone {
    move |s| {
        gibake_asset::parse_tolerance(flag, s)
            .map(|v| v as f32)
            .map_err(|e| e.to_string())
    }
}

/// Like [`tolerance_f32`], for `--max-texels-over` (a fraction).
pub fn tolerance_f64(flag: &'static str) -> impl Fn(&str) -> Result<f64, String> + Clone {
    move |s| gibake_asset::parse_tolerance(flag, s).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes() {
        assert_eq!(parse_size("1024"), Ok(1024));
        assert_eq!(parse_size("2G"), Ok(2 << 30));
        assert_eq!(parse_size("512MiB"), Ok(512 << 20));
        assert_eq!(parse_size("3kb"), Ok(3 << 10));
        assert!(parse_size("0").is_err());
        assert!(parse_size("-1G").is_err());
        assert!(parse_size("99999999T").is_err());
        assert!(parse_size("lots").is_err());
    }
}
