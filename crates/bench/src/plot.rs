//! The plots of `gibake bench`, drawn with `plotters` (its bitmap backend,
//! into memory) and written as PNG by `gibake_image::write_rgb8_png`, so the
//! workspace holds one PNG encoder. Text is drawn with the DejaVu Sans font embedded in the
//! crate (`crates/bench/assets/`, its licence beside it) by [`crate::text`]
//! (skrifa and ab_glyph_rasterizer, not plotters' font features, whose
//! `ttf-parser` is unmaintained), so no system font or fontconfig is needed.

use std::path::Path;

use crate::error::BenchError;
use plotters::prelude::*;

use crate::text::TextBitmap;

/// The font family the plots ask for (one font is embedded: see [`crate::text`]).
const FAMILY: &str = "sans-serif";
/// Plot size in pixels.
const W: u32 = 900;
const H: u32 = 600;

const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// One point of an error-against-time plot.
#[derive(Clone, Debug)]
pub(super) struct Point {
    /// Legend entry (mode, interleave...).
    pub(super) series: String,
    /// Time (ms).
    pub(super) ms: f64,
    /// Error.
    pub(super) err: f64,
    /// On the Pareto front of its plot.
    pub(super) front: bool,
}

/// `(lo, hi)` around the positive finite values of `v`, with a margin of
/// a quarter of the spread in log space (at least ×1.25 each side).
fn log_range(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = v
        .filter(|x| x.is_finite() && *x > 0.0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| {
            (l.min(x), h.max(x))
        });
    if lo.is_finite() && hi.is_finite() {
        let m = (hi / lo).powf(0.08).max(1.25);
        (lo / m, hi * m)
    } else {
        (1.0, 10.0)
    }
}

/// An axis label: 3 significant digits, no float noise.
fn axis_label(v: &f64) -> String {
    super::report::sig(*v)
}

fn series_names<'a>(names: impl Iterator<Item = &'a str>) -> Vec<&'a str> {
    let mut out: Vec<&str> = Vec::new();
    for n in names {
        if !out.contains(&n) {
            out.push(n);
        }
    }
    out
}

/// A log-log scatter plot of error against time, one colour per series,
/// the Pareto front ringed in black and joined by a line.
pub(super) fn error_vs_time(
    path: &Path,
    title: &str,
    y_desc: &str,
    points: &[Point],
) -> crate::Result<()> {
    let good: Vec<&Point> = points
        .iter()
        .filter(|p| p.ms > 0.0 && p.err > 0.0 && p.ms.is_finite() && p.err.is_finite())
        .collect();
    let (x0, x1) = log_range(good.iter().map(|p| p.ms));
    let (y0, y1) = log_range(good.iter().map(|p| p.err));
    let mut rgb = vec![0u8; (W * H * 3) as usize];
    let root = TextBitmap(BitMapBackend::with_buffer(&mut rgb, (W, H))).into_drawing_area();
    let e =
        |e: &dyn std::fmt::Display| BenchError::Invalid(format!("plot {}: {e}", path.display()));
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let mut chart = log_log_chart(
        &root,
        title,
        (x0, x1),
        (y0, y1),
        "time per frame (ms, log)",
        y_desc,
    )
    .map_err(|x| e(&x))?;
    let mut front: Vec<(f64, f64)> = good
        .iter()
        .filter(|p| p.front)
        .map(|p| (p.ms, p.err))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    chart
        .draw_series(LineSeries::new(
            front.iter().copied(),
            BLACK.stroke_width(1),
        ))
        .map_err(|x| e(&x))?
        .label("Pareto front (ringed)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK));
    for (i, name) in series_names(good.iter().map(|p| p.series.as_str()))
        .into_iter()
        .enumerate()
    {
        let c = COLOURS[i % COLOURS.len()];
        chart
            .draw_series(
                good.iter()
                    .filter(|p| p.series == name)
                    .map(|p| Circle::new((p.ms, p.err), 4, c.mix(0.85).filled())),
            )
            .map_err(|x| e(&x))?
            .label(name)
            .legend(move |(x, y)| Circle::new((x + 8, y), 4, c.filled()));
    }
    chart
        .draw_series(
            good.iter()
                .filter(|p| p.front)
                .map(|p| Circle::new((p.ms, p.err), 7, BLACK.stroke_width(2))),
        )
        .map_err(|x| e(&x))?;
    legend(&mut chart, SeriesLabelPosition::UpperRight).map_err(|x| e(&x))?;
    root.present().map_err(|x| e(&x))?;
    drop(chart);
    drop(root);
    gibake_image::write_rgb8_png(path, W, H, &rgb)?;
    Ok(())
}

/// One series of a scaling plot: measured points and the fitted power law.
pub(super) struct Curve {
    /// Legend entry (with the fitted exponent).
    pub(super) name: String,
    /// `(x, ms)`.
    pub(super) points: Vec<(f64, f64)>,
    /// `(scale, exponent)` of the fit, drawn as a dashed-looking thin line.
    pub(super) fit: Option<(f64, f64)>,
}

/// A log-log plot of time against a size, points and fitted lines.
pub(super) fn scaling(
    path: &Path,
    title: &str,
    x_desc: &str,
    curves: &[Curve],
) -> crate::Result<()> {
    let (x0, x1) = log_range(curves.iter().flat_map(|c| c.points.iter().map(|p| p.0)));
    let (y0, y1) = log_range(curves.iter().flat_map(|c| c.points.iter().map(|p| p.1)));
    let mut rgb = vec![0u8; (W * H * 3) as usize];
    let root = TextBitmap(BitMapBackend::with_buffer(&mut rgb, (W, H))).into_drawing_area();
    let e =
        |e: &dyn std::fmt::Display| BenchError::Invalid(format!("plot {}: {e}", path.display()));
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let mut chart = log_log_chart(
        &root,
        title,
        (x0, x1),
        (y0, y1),
        x_desc,
        "GPU time per frame (ms, log)",
    )
    .map_err(|x| e(&x))?;
    for (i, c) in curves.iter().enumerate() {
        let col = COLOURS[i % COLOURS.len()];
        let pts: Vec<(f64, f64)> = c
            .points
            .iter()
            .copied()
            .filter(|p| p.0 > 0.0 && p.1 > 0.0 && p.0.is_finite() && p.1.is_finite())
            .collect();
        chart
            .draw_series(pts.iter().map(|p| Circle::new(*p, 5, col.filled())))
            .map_err(|x| e(&x))?
            .label(c.name.as_str())
            .legend(move |(x, y)| Circle::new((x + 8, y), 4, col.filled()));
        if let Some((scale, k)) = c.fit {
            let (lo, hi) = pts
                .iter()
                .fold((f64::INFINITY, 0f64), |(l, h), p| (l.min(p.0), h.max(p.0)));
            if lo.is_finite() && hi > 0.0 {
                let line: Vec<(f64, f64)> = (0..=32)
                    .map(|j| {
                        let x = lo * (hi / lo).powf(f64::from(j) / 32.0);
                        (x, scale * x.powf(k))
                    })
                    .collect();
                chart
                    .draw_series(LineSeries::new(line, col.stroke_width(1)))
                    .map_err(|x| e(&x))?;
            }
        }
    }
    legend(&mut chart, SeriesLabelPosition::UpperLeft).map_err(|x| e(&x))?;
    root.present().map_err(|x| e(&x))?;
    drop(chart);
    drop(root);
    gibake_image::write_rgb8_png(path, W, H, &rgb)?;
    Ok(())
}

/// Log-log axes drawn into an in-memory bitmap.
type LogLogChart<'a, 'b> =
    ChartContext<'a, TextBitmap<'b>, Cartesian2d<LogCoord<f64>, LogCoord<f64>>>;
/// A plotters drawing error of the bitmap backend.
type PlotError<'b> = DrawingAreaErrorKind<<TextBitmap<'b> as DrawingBackend>::ErrorType>;

/// Log-log axes with the caption, labels and mesh every plot uses.
fn log_log_chart<'a, 'b>(
    root: &'a DrawingArea<TextBitmap<'b>, plotters::coord::Shift>,
    title: &str,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    x_desc: &str,
    y_desc: &str,
) -> Result<LogLogChart<'a, 'b>, PlotError<'b>> {
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FAMILY, 18))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .x_label_formatter(&axis_label)
        .y_label_formatter(&axis_label)
        .y_desc(y_desc)
        .label_style((FAMILY, 13))
        .draw()?;
    Ok(chart)
}

/// Draws the legend box of `chart` at `pos` (the one legend style).
fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    pos: SeriesLabelPosition,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    chart
        .configure_series_labels()
        .label_font((FAMILY, 13))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(pos)
        .draw()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png_size(path: &Path) -> (u32, u32) {
        let bytes = std::fs::read(path).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        let be =
            |i: usize| u32::from_be_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
        (be(16), be(20))
    }

    #[test]
    fn plots_are_pngs_with_text() {
        let dir = tempfile::tempdir().unwrap();
        let pts = vec![
            Point {
                series: "full".into(),
                ms: 10.0,
                err: 0.01,
                front: true,
            },
            Point {
                series: "rsm".into(),
                ms: 5.0,
                err: 0.1,
                front: true,
            },
            Point {
                series: "rsm".into(),
                ms: 50.0,
                err: 0.2,
                front: false,
            },
        ];
        let p = dir.path().join("q.png");
        error_vs_time(&p, "title", "rel MSE", &pts).unwrap();
        assert_eq!(png_size(&p), (900, 600));
        let s = dir.path().join("s.png");
        scaling(
            &s,
            "t",
            "x",
            &[Curve {
                name: "update".into(),
                points: vec![(1.0, 2.0), (4.0, 8.0)],
                fit: Some((2.0, 1.0)),
            }],
        )
        .unwrap();
        assert_eq!(png_size(&s), (900, 600));
        // Text is drawn: the plot with a caption differs from one without.
        let q = dir.path().join("q2.png");
        error_vs_time(&q, "a different, much longer title", "rel MSE", &pts).unwrap();
        assert_ne!(std::fs::read(&p).unwrap(), std::fs::read(&q).unwrap());
    }
}
