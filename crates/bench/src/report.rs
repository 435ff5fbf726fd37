//! The shared report code of `gibake bench`: Markdown tables, sections, the
//! JSON files, medians and sizes.

use std::fmt::Write as _;
use std::path::Path;

use serde_json::Value;

use super::Bench;
use crate::out::write_atomic;

/// A Markdown table.
pub(crate) struct Table {
    pub(crate) title: String,
    pub(crate) head: Vec<&'static str>,
    pub(crate) rows: Vec<Vec<String>>,
    pub(crate) notes: Vec<String>,
}

impl Table {
    pub(crate) fn new(title: String, head: &[&'static str]) -> Table {
        Table {
            title,
            head: head.to_vec(),
            rows: Vec::new(),
            notes: Vec::new(),
        }
    }

    pub(crate) fn row(&mut self, cells: Vec<String>) {
        self.rows.push(cells);
    }

    pub(crate) fn markdown(&self) -> String {
        let mut s = format!("#### {}\n\n", self.title);
        let _ = writeln!(s, "| {} |", self.head.join(" | "));
        let _ = writeln!(
            s,
            "|{}",
            self.head
                .iter()
                .enumerate()
                .map(|(i, _)| if i == 0 { " --- |" } else { " ---: |" })
                .collect::<String>()
        );
        for r in &self.rows {
            let _ = writeln!(s, "| {} |", r.join(" | "));
        }
        for n in &self.notes {
            let _ = write!(s, "\n{n}\n");
        }
        s.push('\n');
        s
    }
}

impl Bench {
    /// Prints a table and appends it to the report.
    pub(super) fn emit(&mut self, t: &Table) {
        let md = t.markdown();
        crate::out::print_stdout(&md);
        self.report.push_str(&md);
    }

    /// Starts a section of the report.
    pub(super) fn section(&mut self, title: &str) {
        let _ = writeln!(self.report, "## {title}\n");
    }

    /// Writes `DIR/NAME.json`.
    pub(super) fn write_json(&self, name: &str, v: &Value) -> crate::Result<()> {
        write_atomic(
            &self.out.join(format!("{name}.json")),
            serde_json::to_string_pretty(v)?.as_bytes(),
        )
    }

    /// Records a plot written into the output directory and links it in the
    /// report with the command that reproduces it.
    pub(super) fn plot_written(&mut self, file: &str, which: &str) {
        let cmd = self.command(which);
        let _ = writeln!(
            self.report,
            "![{file}]({file})\n\nPlot `{file}` — reproduce: `{cmd}`.\n"
        );
        self.plots.push((file.to_string(), cmd));
    }
}

/// Median of `v` (NaN when empty).
pub(crate) fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// Bytes of the files directly in `dir`.
pub(super) fn dir_bytes(dir: &Path) -> u64 {
    std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(Result::ok)
                .filter_map(|e| e.metadata().ok())
                .filter(|m| m.is_file())
                .map(|m| m.len())
                .sum()
        })
        .unwrap_or(0)
}

/// `bytes` in MiB, for a table.
pub(super) fn mib(bytes: u64) -> String {
    format!("{:.1} MiB", bytes as f64 / (1024.0 * 1024.0))
}

/// A number for a table: 3 significant digits, or "—" when not finite.
pub(super) fn sig(v: f64) -> String {
    if !v.is_finite() {
        return "—".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    if digits > 6 {
        format!("{v:.2e}")
    } else {
        format!("{v:.digits$}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&[]).is_nan());
    }

    #[test]
    fn table_is_markdown() {
        let mut t = Table::new("T".into(), &["a", "b"]);
        t.row(vec!["x".into(), "1".into()]);
        let md = t.markdown();
        assert!(md.contains("| a | b |\n| --- | ---: |\n| x | 1 |"), "{md}");
    }

    #[test]
    fn significant_digits() {
        assert_eq!(sig(0.012345), "0.0123");
        assert_eq!(sig(123.45), "123");
        assert_eq!(sig(1.5), "1.50");
        assert_eq!(sig(f64::NAN), "—");
    }
}
