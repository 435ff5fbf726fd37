//! External files: percent-decodes relative URIs, resolves them against the
//! glTF's directory (within the limits' allowed roots) and reads them.

use std::path::PathBuf;

use super::Ctx;
use crate::SceneError;
use crate::limits;

/// Percent-decodes a relative URI (malformed escapes are kept literally).
pub(super) fn percent_decode(uri: &str) -> Option<String> {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    let hex = |c: u8| (c as char).to_digit(16).map(|d| d as u8);
    while i < b.len() {
        if b[i] == b'%'
            && i + 2 < b.len()
            && let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2]))
        {
            out.push(h << 4 | l);
            i += 3;
            continue;
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8(out).ok()
}

impl<'a> Ctx<'a> {
    /// Resolves a non-data URI to a file path.
    pub(super) fn resolve_uri(&self, uri: &str, what: &str) -> Result<PathBuf, SceneError> {
        let file = self.resolve_uri_unchecked(uri, what)?;
        if !self.limits.allow_outside_uris && !limits::is_inside(&self.base, &file) {
            return Err(self.invalid(format!(
                "{what}: URI '{uri}' points outside the scene's directory {} (to {}); pass --allow-outside-uris to allow it",
                self.base.display(),
                file.display()
            )));
        }
        Ok(file)
    }

    pub(super) fn resolve_uri_unchecked(
        &self,
        uri: &str,
        what: &str,
    ) -> Result<PathBuf, SceneError> {
        if let Some(rest) = uri
            .strip_prefix("file://")
            .or_else(|| uri.strip_prefix("file:"))
        {
            return Ok(PathBuf::from(rest));
        }
        if uri.contains(':') {
            return Err(self.not_supported(format!(
                "{what}: URI scheme of '{uri}' (only relative paths, file: and data: URIs)"
            )));
        }
        let decoded = percent_decode(uri).ok_or_else(|| {
            self.invalid(format!(
                "{what}: URI '{uri}' is not valid UTF-8 once percent-decoded"
            ))
        })?;
        Ok(self.base.join(decoded))
    }

    pub(super) fn read_external(
        &self,
        uri: &str,
        what: &str,
    ) -> Result<(PathBuf, Vec<u8>), SceneError> {
        let file = self.resolve_uri(uri, what)?;
        match limits::read_regular(&file, self.limits.max_input_bytes) {
            Ok(b) => Ok((file, b)),
            Err(e) => Err(self.invalid(format!(
                "{what}: cannot read '{uri}' ({}): {e}",
                file.display()
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b.bin").as_deref(), Some("a b.bin"));
        assert_eq!(percent_decode("100%").as_deref(), Some("100%"));
        assert_eq!(percent_decode("%zz").as_deref(), Some("%zz"));
        assert_eq!(percent_decode("%FF"), None);
    }
}
