//! Parsing and checking of `gibake diff`'s tolerance values, so that no flag
//! value can make `diff` pass what it should catch: every tolerance is a
//! finite number in `[0, 1]` (a relative tolerance above 1, or a fraction of
//! texels above 1, accepts any two maps; NaN compares false both ways;
//! a negative one can never pass).

use crate::Tolerance;

/// A tolerance value that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ToleranceError {
    /// Not a decimal number.
    #[error("{flag}: '{text}' is not a number")]
    NotANumber {
        /// The flag (e.g. `--map-rel`).
        flag: String,
        /// What was given.
        text: String,
    },
    /// NaN, infinite, negative or above 1.
    #[error(
        "{flag}: {value} is not allowed; a tolerance must be a finite number from 0 to 1 (above 1 it accepts any difference)"
    )]
    OutOfRange {
        /// The flag.
        flag: String,
        /// The value.
        value: f64,
    },
}

/// The largest accepted tolerance value.
pub const MAX_TOLERANCE: f64 = 1.0;

/// Parses the text of tolerance flag `flag` (`--map-rel`, `--max-texels-over`,
/// `--vpl-position-rel`, `--vpl-flux-rel`): a finite number in `[0, 1]`.
pub fn parse_tolerance(flag: &str, text: &str) -> Result<f64, ToleranceError> {
    let value: f64 = text
        .trim()
        .parse()
        .map_err(|_| ToleranceError::NotANumber {
            flag: flag.to_string(),
            text: text.to_string(),
        })?;
    check_value(flag, value)?;
    Ok(value)
}

fn check_value(flag: &str, value: f64) -> Result<(), ToleranceError> {
    if value.is_finite() && (0.0..=MAX_TOLERANCE).contains(&value) {
        Ok(())
    } else {
        Err(ToleranceError::OutOfRange {
            flag: flag.to_string(),
            value,
        })
    }
}

impl Tolerance {
    /// Checks every value (see [`parse_tolerance`]); the normal-angle
    /// tolerance must be finite and in `[0, 180]` degrees.
    pub fn validate(&self) -> Result<(), ToleranceError> {
        check_value("map_rel", self.map_rel as f64)?;
        check_value("vpl_position_rel", self.vpl_position_rel as f64)?;
        check_value("vpl_flux_rel", self.vpl_flux_rel as f64)?;
        check_value("max_texels_over", self.max_texels_over)?;
        let a = self.map_abs_texels;
        if !(a.is_finite() && a >= 0.0) {
            return Err(ToleranceError::OutOfRange {
                flag: "map_abs_texels".into(),
                value: a as f64,
            });
        }
        let d = self.vpl_normal_deg;
        if !(d.is_finite() && (0.0..=180.0).contains(&d)) {
            return Err(ToleranceError::OutOfRange {
                flag: "vpl_normal_deg".into(),
                value: d as f64,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_that_make_diff_lie_are_refused() {
        for bad in [
            "NaN", "nan", "inf", "-inf", "-1", "5", "1.0001", "", "0x1", "1e400",
        ] {
            assert!(parse_tolerance("--map-rel", bad).is_err(), "{bad}");
        }
        for good in ["0", "1", "0.005", "1e-3", " 0.5 "] {
            assert!(parse_tolerance("--map-rel", good).is_ok(), "{good}");
        }
        assert!(Tolerance::same_machine().validate().is_ok());
        assert!(Tolerance::another_gpu().validate().is_ok());
    }
}
