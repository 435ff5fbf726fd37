//! Text in the bench's plots without `ttf-parser` (unmaintained,
//! RUSTSEC-2026-0192, which plotters' `ab_glyph` font feature pulls in):
//! [`TextBitmap`] is plotters' bitmap backend with its own `draw_text` and
//! `estimate_text_size`, reading the embedded DejaVu Sans with `skrifa`
//! (Google Fonts' maintained parser, the advisory's suggested replacement)
//! and filling glyph outlines with `ab_glyph_rasterizer` (coverage
//! rasterisation only, no font parsing). Everything else is delegated.

use std::sync::OnceLock;

use ab_glyph_rasterizer::{Point, Rasterizer, point};
use plotters::backend::BitMapBackend;
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
};
use skrifa::instance::{LocationRef, Size};
use skrifa::outline::{DrawSettings, OutlinePen};
use skrifa::{FontRef, MetadataProvider};

/// The plots' font (its licence beside it in `crates/bench/assets/`).
const FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// The embedded font, parsed once (`None` if it does not parse: then text
/// is an error, never a panic).
fn font() -> Option<&'static FontRef<'static>> {
    static F: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    F.get_or_init(|| FontRef::new(FONT).ok()).as_ref()
}

/// A text run laid out at a pixel height: its width, its ascent (baseline
/// from the top) and its height, in pixels.
struct Layout {
    width: f32,
    ascent: f32,
    height: f32,
    ppem: f32,
}

/// `size` is the text's pixel height (ascent + descent), as plotters'
/// font backends take it.
fn layout(font: &FontRef<'_>, text: &str, size: f32) -> Layout {
    let unit = font.metrics(Size::unscaled(), LocationRef::default());
    let em_height = (unit.ascent - unit.descent) / f32::from(unit.units_per_em.max(1));
    let ppem = size / em_height.max(0.1);
    let m = font.metrics(Size::new(ppem), LocationRef::default());
    let gm = font.glyph_metrics(Size::new(ppem), LocationRef::default());
    let cmap = font.charmap();
    let width = text
        .chars()
        .map(|c| {
            let id = cmap.map(c).unwrap_or_default();
            gm.advance_width(id).unwrap_or(0.0)
        })
        .sum();
    Layout {
        width,
        ascent: m.ascent,
        height: m.ascent - m.descent,
        ppem,
    }
}

/// Feeds an outline into the rasteriser, offset by `(x, baseline)`, y down.
struct Pen<'a> {
    r: &'a mut Rasterizer,
    x: f32,
    baseline: f32,
    start: Point,
    last: Point,
}

impl Pen<'_> {
    fn p(&self, x: f32, y: f32) -> Point {
        point(self.x + x, self.baseline - y)
    }
}

impl OutlinePen for Pen<'_> {
    fn move_to(&mut self, x: f32, y: f32) {
        self.start = self.p(x, y);
        self.last = self.start;
    }
    fn line_to(&mut self, x: f32, y: f32) {
        let p = self.p(x, y);
        self.r.draw_line(self.last, p);
        self.last = p;
    }
    fn quad_to(&mut self, cx0: f32, cy0: f32, x: f32, y: f32) {
        let (c, p) = (self.p(cx0, cy0), self.p(x, y));
        self.r.draw_quad(self.last, c, p);
        self.last = p;
    }
    fn curve_to(&mut self, cx0: f32, cy0: f32, cx1: f32, cy1: f32, x: f32, y: f32) {
        let (c0, c1, p) = (self.p(cx0, cy0), self.p(cx1, cy1), self.p(x, y));
        self.r.draw_cubic(self.last, c0, c1, p);
        self.last = p;
    }
    fn close(&mut self) {
        if self.last != self.start {
            self.r.draw_line(self.last, self.start);
        }
        self.last = self.start;
    }
}

/// The coverage of `text` at pixel height `size`: `(width, height, alpha)`,
/// row-major, row 0 at the top.
fn rasterise(font: &FontRef<'_>, text: &str, size: f32) -> (usize, usize, Vec<f32>) {
    let l = layout(font, text, size);
    let (w, h) = (l.width.ceil() as usize + 2, l.height.ceil() as usize + 2);
    let mut r = Rasterizer::new(w, h);
    let outlines = font.outline_glyphs();
    let gm = font.glyph_metrics(Size::new(l.ppem), LocationRef::default());
    let cmap = font.charmap();
    let mut x = 1.0;
    for c in text.chars() {
        let id = cmap.map(c).unwrap_or_default();
        if let Some(g) = outlines.get(id) {
            let mut pen = Pen {
                r: &mut r,
                x,
                baseline: 1.0 + l.ascent,
                start: point(0.0, 0.0),
                last: point(0.0, 0.0),
            };
            let settings = DrawSettings::unhinted(Size::new(l.ppem), LocationRef::default());
            let _ = g.draw(settings, &mut pen);
        }
        x += gm.advance_width(id).unwrap_or(0.0);
    }
    let mut alpha = vec![0.0; w * h];
    r.for_each_pixel_2d(|px, py, a| alpha[py as usize * w + px as usize] = a.min(1.0));
    (w, h, alpha)
}

/// Plotters' bitmap backend with the text of this module (see the module docs).
pub(super) struct TextBitmap<'a>(pub(super) BitMapBackend<'a>);

type Err<'a> = DrawingErrorKind<<BitMapBackend<'a> as DrawingBackend>::ErrorType>;

fn no_font<E: std::error::Error + Send + Sync>() -> DrawingErrorKind<E> {
    DrawingErrorKind::FontError(Box::new(std::io::Error::other(
        "the embedded plot font does not load",
    )))
}

impl<'a> DrawingBackend for TextBitmap<'a> {
    type ErrorType = <BitMapBackend<'a> as DrawingBackend>::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.0.get_size()
    }
    fn ensure_prepared(&mut self) -> Result<(), Err<'a>> {
        self.0.ensure_prepared()
    }
    fn present(&mut self) -> Result<(), Err<'a>> {
        self.0.present()
    }
    fn draw_pixel(&mut self, p: BackendCoord, c: BackendColor) -> Result<(), Err<'a>> {
        self.0.draw_pixel(p, c)
    }
    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), Err<'a>> {
        self.0.draw_line(from, to, style)
    }
    fn draw_rect<S: BackendStyle>(
        &mut self,
        a: BackendCoord,
        b: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), Err<'a>> {
        self.0.draw_rect(a, b, style, fill)
    }
    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), Err<'a>> {
        self.0.draw_path(path, style)
    }
    fn draw_circle<S: BackendStyle>(
        &mut self,
        c: BackendCoord,
        r: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), Err<'a>> {
        self.0.draw_circle(c, r, style, fill)
    }
    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), Err<'a>> {
        self.0.fill_polygon(vert, style)
    }
    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), Err<'a>> {
        self.0.blit_bitmap(pos, size, src)
    }

    fn estimate_text_size<T: BackendTextStyle>(
        &self,
        text: &str,
        style: &T,
    ) -> Result<(u32, u32), Err<'a>> {
        let font = font().ok_or_else(no_font)?;
        let l = layout(font, text, style.size() as f32);
        Ok((l.width.ceil() as u32, l.height.ceil() as u32))
    }

    fn draw_text<T: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &T,
        pos: BackendCoord,
    ) -> Result<(), Err<'a>> {
        let color = style.color();
        if color.alpha == 0.0 || text.is_empty() {
            return Ok(());
        }
        let font = font().ok_or_else(no_font)?;
        let (w, h, alpha) = rasterise(font, text, style.size() as f32);
        // The anchor, as plotters' own text drawing places it (the raster
        // has a 1-pixel margin on each side).
        let (tw, th) = (w as i32 - 2, h as i32 - 2);
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -tw,
            HPos::Center => -tw / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -th / 2,
            VPos::Bottom => -th,
        };
        let trans = style.transform();
        let (bw, bh) = self.get_size();
        for y in 0..h {
            for x in 0..w {
                let a = alpha[y * w + x];
                if a <= 0.0 {
                    continue;
                }
                let (tx, ty) = trans.transform(x as i32 - 1 + dx, y as i32 - 1 + dy);
                let (px, py) = (pos.0 + tx, pos.1 + ty);
                if px >= 0 && px < bw as i32 && py >= 0 && py < bh as i32 {
                    let c = BackendColor {
                        alpha: color.alpha * f64::from(a),
                        rgb: color.rgb,
                    };
                    self.0.draw_pixel((px, py), c)?;
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_font_loads_and_text_has_ink_of_the_right_size() {
        let font = font().expect("embedded font");
        let (w, h, a) = rasterise(font, "Error vs time", 18.0);
        assert!((17..=24).contains(&h), "{h}");
        assert!(w > 80 && w < 160, "{w}");
        let ink: f32 = a.iter().sum();
        assert!(ink > 100.0, "{ink}");
        // Wider text is wider.
        assert!(layout(font, "WWWW", 13.0).width > layout(font, "iiii", 13.0).width);
    }
}
