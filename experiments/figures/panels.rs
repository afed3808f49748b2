//! Multi-panel figures with their labels in the pixels: a grid of images
//! with a name at the start of each row (the mode, the case) and a heading
//! over each column (the frame, the time with its unit), and an optional
//! title. A figure that is read without its caption still says what each
//! panel is.
//!
//! [`save`] writes such a figure with its caption, generated from the same
//! labels, into `figures.json` beside it (file name → caption), which the
//! gallery and the paper use, so that no caption can disagree with the
//! picture.
//!
//! Text is drawn with the plots' embedded DejaVu Sans ([`crate::figures::plot`]),
//! through plotters' bitmap backend over the composed image's buffer.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{anyhow, ensure, Context as _, Result};
use image::{Rgb, RgbImage};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Background of the margins and gaps.
const BACKGROUND: Rgb<u8> = Rgb([28, 28, 28]);
/// Colour of the labels.
const INK: RGBColor = RGBColor(235, 235, 235);

/// How a [`grid`] is labelled: one name per row, one heading per column
/// (either may be empty for none), and a title over the whole (empty for
/// none).
#[derive(Clone, Debug, Default)]
pub struct Labels<'a> {
    pub title: &'a str,
    pub rows: &'a [String],
    pub columns: &'a [String],
}

/// The heading of a column showing frame `frame` of a run stepped by `dt`:
/// `frame 50, t = 2.5 s` (the time to three decimals, trailing zeros cut).
pub fn frame_heading(frame: usize, dt: f32) -> String {
    let t = format!("{:.3}", f64::from(dt) * frame as f64);
    let t = t.trim_end_matches('0').trim_end_matches('.');
    format!("frame {frame}, t = {t} s")
}

/// The text height in pixels for panels of `panel_side` (the smaller of
/// their width and height): legible at the figure's size, never smaller
/// than 11 px nor larger than 28 px.
fn text_size(panel_side: u32) -> u32 {
    (panel_side / 12).clamp(11, 28)
}

/// The width in pixels of `text` drawn `size` pixels high in the labels'
/// font (0 for no text).
///
/// # Errors
/// If the font cannot lay the text out.
fn text_width(text: &str, size: u32) -> Result<u32> {
    if text.is_empty() {
        return Ok(0);
    }
    crate::figures::plot::ensure_font();
    let font = (crate::figures::plot::FAMILY, f64::from(size)).into_font();
    let (w, _) = font
        .box_size(text)
        .map_err(|e| anyhow!("panels: measuring the label {text:?}: {e:?}"))?;
    Ok(w)
}

/// The width in pixels of the widest of `texts` drawn `size` pixels high (0
/// for none).
///
/// # Errors
/// If the font cannot lay a text out.
fn widest(texts: &[String], size: u32) -> Result<u32> {
    texts
        .iter()
        .try_fold(0, |w, text| Ok(w.max(text_width(text, size)?)))
}

/// The panels `rows[r][c]` in a grid, `gap` pixels apart, with `labels`
/// drawn in margins left of the rows and above the columns.
///
/// Rows may differ in length (a missing panel is left blank); each cell is
/// as large as the largest panel in its row and column. A title wider than
/// the panels, or a heading wider than its column, wraps at spaces onto more
/// lines; the figure is wider than the panels only for a title word that is.
///
/// # Errors
/// If there are no panels, or a label list is neither empty nor as long as
/// the rows / the longest row.
pub fn grid(rows: &[Vec<RgbImage>], gap: u32, labels: &Labels) -> Result<RgbImage> {
    let n_cols = rows.iter().map(Vec::len).max().unwrap_or(0);
    ensure!(n_cols > 0, "panels::grid: no panels");
    ensure!(
        labels.rows.is_empty() || labels.rows.len() == rows.len(),
        "panels::grid: {} row labels for {} rows",
        labels.rows.len(),
        rows.len()
    );
    ensure!(
        labels.columns.is_empty() || labels.columns.len() == n_cols,
        "panels::grid: {} column labels for {} columns",
        labels.columns.len(),
        n_cols
    );
    let widths: Vec<u32> = (0..n_cols)
        .map(|c| {
            rows.iter()
                .filter_map(|r| r.get(c))
                .map(|i| i.width())
                .max()
                .unwrap_or(0)
        })
        .collect();
    let heights: Vec<u32> = rows
        .iter()
        .map(|r| r.iter().map(|i| i.height()).max().unwrap_or(0))
        .collect();
    let side = heights
        .iter()
        .chain(&widths)
        .copied()
        .filter(|&s| s > 0)
        .min();
    let size = text_size(side.unwrap_or(0));
    let line = size + size / 2;
    // Margins: the widest row name as drawn plus half a line either side;
    // above the panels, a line per line of the title and of the most
    // wrapped column heading.
    let names = widest(labels.rows, size)?;
    let left = if names > 0 { names + size } else { 0 };
    let panels_width = left + widths.iter().sum::<u32>() + gap * (n_cols as u32 - 1);
    // A title wider than the panels wraps onto more lines; only a word wider
    // than the panels on its own widens the figure rather than be cut.
    let title = wrap(labels.title, panels_width.saturating_sub(size), size)?;
    let width = panels_width.max(widest(&title, size)? + size);
    // Headings wider than their column wrap too, ending above the panels.
    let headings = labels
        .columns
        .iter()
        .zip(&widths)
        .map(|(text, &w)| wrap(text, w, size))
        .collect::<Result<Vec<_>>>()?;
    let heading_lines = headings.iter().map(Vec::len).max().unwrap_or(0);
    let top = (title.len() + heading_lines) as u32 * line;
    let height = top + heights.iter().sum::<u32>() + gap * (rows.len() as u32 - 1);
    let mut out = RgbImage::from_pixel(width, height, BACKGROUND);
    let mut y = top;
    for (row, &h) in rows.iter().zip(&heights) {
        let mut x = left;
        for (img, &w) in row.iter().zip(&widths) {
            image::imageops::replace(&mut out, img, i64::from(x), i64::from(y));
            x += w + gap;
        }
        y += h + gap;
    }
    draw_labels(
        &mut out,
        (&title, &headings, labels.rows),
        (left, top, line, size),
        (&widths, &heights),
        gap,
    )?;
    Ok(out)
}

/// `text` broken at spaces into lines at most `width` pixels wide as drawn
/// `size` pixels high (a word wider than that alone on its line); no lines
/// for no text.
///
/// # Errors
/// If the font cannot lay the text out.
fn wrap(text: &str, width: u32, size: u32) -> Result<Vec<String>> {
    let mut lines: Vec<String> = vec![];
    for word in text.split_whitespace() {
        match lines.last_mut() {
            Some(last) if text_width(&format!("{last} {word}"), size)? <= width => {
                last.push(' ');
                last.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    Ok(lines)
}

/// The caption of a [`grid`] labelled `labels`: its title, then what its
/// rows and columns are, in the order they appear.
pub fn caption(labels: &Labels) -> String {
    let mut parts = vec![];
    if !labels.title.is_empty() {
        parts.push(labels.title.to_string());
    }
    if !labels.rows.is_empty() {
        parts.push(format!("Rows, top to bottom: {}", labels.rows.join("; ")));
    }
    if !labels.columns.is_empty() {
        parts.push(format!(
            "Columns, left to right: {}",
            labels.columns.join("; ")
        ));
    }
    parts.join(". ") + "."
}

/// The file in a figure's folder that maps its figures' file names to their
/// captions.
pub const CAPTIONS: &str = "figures.json";

/// [`grid`] written to `path` (PNG), and its [`caption`] recorded under the
/// file's name in [`CAPTIONS`] beside it (other entries kept).
///
/// # Errors
/// As [`grid`]; an unwritable folder, or a [`CAPTIONS`] file that is not a
/// map of strings.
pub fn save(path: &Path, rows: &[Vec<RgbImage>], gap: u32, labels: &Labels) -> Result<()> {
    smokelab::io::write_png(path, &grid(rows, gap, labels)?)?;
    let name = path
        .file_name()
        .with_context(|| format!("{}: not a file path", path.display()))?
        .to_string_lossy()
        .into_owned();
    let file = path.with_file_name(CAPTIONS);
    let mut captions = read_captions(&file)?;
    captions.insert(name, caption(labels));
    smokelab::io::write_json(&file, &captions)
}

/// The captions of a [`CAPTIONS`] file (empty if there is none).
///
/// # Errors
/// A file that cannot be read or is not a map of strings.
pub fn read_captions(file: &Path) -> Result<BTreeMap<String, String>> {
    match std::fs::read_to_string(file) {
        Ok(text) => serde_json::from_str(&text)
            .with_context(|| format!("{}: not a map of file names to captions", file.display())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(BTreeMap::new()),
        Err(e) => Err(e).with_context(|| format!("cannot read {}", file.display())),
    }
}

/// One row of panels with a heading over each, as [`grid`].
///
/// # Errors
/// As [`grid`].
pub fn row(images: &[RgbImage], gap: u32, title: &str, headings: &[String]) -> Result<RgbImage> {
    grid(
        &[images.to_vec()],
        gap,
        &Labels {
            title,
            rows: &[],
            columns: headings,
        },
    )
}

/// [`row`] written to `path` with its caption, as [`save`].
///
/// # Errors
/// As [`save`].
pub fn save_row(
    path: &Path,
    images: &[RgbImage],
    gap: u32,
    title: &str,
    headings: &[String],
) -> Result<()> {
    let labels = Labels {
        title,
        rows: &[],
        columns: headings,
    };
    save(path, &[images.to_vec()], gap, &labels)
}

/// The labels of [`grid`] written into `out`, whose panel area starts at
/// `(left, top)`: the title's lines, each column heading's lines and the
/// row names.
fn draw_labels(
    out: &mut RgbImage,
    (title, headings, rows): (&[String], &[Vec<String>], &[String]),
    (left, top, line, size): (u32, u32, u32, u32),
    (widths, heights): (&[u32], &[u32]),
    gap: u32,
) -> Result<()> {
    crate::figures::plot::ensure_font();
    let (w, h) = out.dimensions();
    let root = BitMapBackend::with_buffer(out.as_mut(), (w, h)).into_drawing_area();
    let font = |h: HPos, v: VPos| {
        (crate::figures::plot::FAMILY, size as f64)
            .into_font()
            .color(&INK)
            .pos(Pos::new(h, v))
    };
    let err = |e| anyhow!("panels: drawing a label: {e:?}");
    for (i, text) in title.iter().enumerate() {
        let style = font(HPos::Center, VPos::Center);
        let y = i as u32 * line + line / 2;
        root.draw_text(text, &style, ((w / 2) as i32, y as i32))
            .map_err(err)?;
    }
    let mut x = left;
    for (lines, &cw) in headings.iter().zip(widths) {
        let style = font(HPos::Center, VPos::Center);
        for (i, text) in lines.iter().enumerate() {
            let y = top - (lines.len() - i) as u32 * line + line / 2;
            root.draw_text(text, &style, ((x + cw / 2) as i32, y as i32))
                .map_err(err)?;
        }
        x += cw + gap;
    }
    let mut y = top;
    for (text, &rh) in rows.iter().zip(heights) {
        let style = font(HPos::Right, VPos::Center);
        root.draw_text(
            text,
            &style,
            ((left - size / 2) as i32, (y + rh / 2) as i32),
        )
        .map_err(err)?;
        y += rh + gap;
    }
    root.present().map_err(err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn panel(w: u32, h: u32, v: u8) -> RgbImage {
        RgbImage::from_pixel(w, h, Rgb([v, v, v]))
    }

    /// Count of pixels in `rect` that differ from the background.
    fn inked(img: &RgbImage, (x0, y0, x1, y1): (u32, u32, u32, u32)) -> usize {
        (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .filter(|&(x, y)| *img.get_pixel(x, y) != BACKGROUND)
            .count()
    }

    #[test]
    fn labels_land_in_the_margins_and_panels_stay_whole() {
        let rows = vec![
            vec![panel(100, 80, 0), panel(100, 80, 255)],
            vec![panel(100, 80, 128)],
        ];
        let names = ["gridded".to_string(), "gridless".to_string()];
        let heads = ["t = 1 s".to_string(), "t = 2 s".to_string()];
        let labels = Labels {
            title: "title",
            rows: &names,
            columns: &heads,
        };
        let img = grid(&rows, 4, &labels).unwrap();
        let size = text_size(80);
        assert_eq!(frame_heading(9, 0.05), "frame 9, t = 0.45 s");
        assert_eq!(frame_heading(20, 0.05), "frame 20, t = 1 s");
        let line = size + size / 2;
        let left = text_width("gridless", size).unwrap() + size;
        assert_eq!(img.width(), left + 204);
        assert_eq!(img.height(), 2 * line + 164);
        // Each label put ink in its own margin cell.
        assert!(inked(&img, (0, 0, img.width(), line)) > 20, "title");
        assert!(
            inked(&img, (left, line, left + 100, 2 * line)) > 20,
            "first column heading"
        );
        assert!(
            inked(&img, (left + 104, line, left + 204, 2 * line)) > 20,
            "second heading"
        );
        assert!(
            inked(&img, (0, 2 * line, left, 2 * line + 80)) > 20,
            "first row name"
        );
        assert!(
            inked(&img, (0, 2 * line + 84, left, 2 * line + 164)) > 20,
            "second row name"
        );
        // The panels are copied untouched, the missing one left blank.
        assert_eq!(*img.get_pixel(left + 50, 2 * line + 40), Rgb([0, 0, 0]));
        assert_eq!(
            *img.get_pixel(left + 150, 2 * line + 40),
            Rgb([255, 255, 255])
        );
        assert_eq!(
            *img.get_pixel(left + 50, 2 * line + 120),
            Rgb([128, 128, 128])
        );
        assert_eq!(
            inked(
                &img,
                (left + 104, 2 * line + 84, left + 204, 2 * line + 164)
            ),
            0
        );
    }

    /// The first and last column of `img` in `rect` that hold ink.
    fn ink_columns(img: &RgbImage, (x0, y0, x1, y1): (u32, u32, u32, u32)) -> (u32, u32) {
        let inked = |x: u32| (y0..y1).any(|y| *img.get_pixel(x, y) != BACKGROUND);
        let first = (x0..x1).find(|&x| inked(x)).expect("no ink");
        let last = (x0..x1).rev().find(|&x| inked(x)).expect("no ink");
        (first, last)
    }

    #[test]
    fn the_label_column_is_as_wide_as_its_widest_label() {
        // Panels 480 px high: labels 28 px high, as in the 640×480 figures.
        let rows = vec![vec![panel(640, 480, 0)], vec![panel(640, 480, 0)]];
        let figure = |names: &[String]| {
            let labels = Labels {
                title: "",
                rows: names,
                columns: &[],
            };
            grid(&rows, 6, &labels).unwrap()
        };
        let short = ["whole cloud".to_string(), "gridded".to_string()];
        let img = figure(&short);
        let left = img.width() - 640;
        // The label's ink starts within a text height of the edge and ends
        // within one of the panels: no empty band beside a short label.
        let (first, last) = ink_columns(&img, (0, 0, left, 480));
        assert!(
            first <= 28 && left - last <= 28,
            "ink {first}–{last} of {left}"
        );
        // 11 characters take under a quarter of the figure.
        assert!(
            left * 4 < img.width(),
            "label column {left} of {}",
            img.width()
        );
        // A longer label widens the column by about its extra text.
        let long = [
            "whole cloud".to_string(),
            "near half cut away at the path".to_string(),
        ];
        let wide = figure(&long);
        let grown = wide.width() - img.width();
        let extra = text_width(&long[1], 28).unwrap() - text_width(&short[0], 28).unwrap();
        assert!(grown == extra && grown > 150, "grew {grown}, text {extra}");
        let (first, _) = ink_columns(&wide, (0, 486, wide.width() - 640, 966));
        assert!(first <= 28, "long label ink starts at {first}");
    }

    /// A title wider than the panels wraps onto lines above them and the
    /// figure keeps the panels' width, every line inked and none cut; a
    /// single word wider than the panels widens the figure instead. A
    /// heading wider than its column wraps within the column, its last line
    /// level with the other headings, just above the panels.
    #[test]
    fn too_wide_titles_and_headings_wrap_onto_lines() {
        let rows = vec![vec![panel(200, 100, 0)]];
        let figure = |title| {
            let labels = Labels {
                title,
                rows: &[],
                columns: &[],
            };
            grid(&rows, 0, &labels).unwrap()
        };
        let title = "a title far longer than one panel of the figure is wide";
        let size = text_size(100);
        let line = size + size / 2;
        assert!(text_width(title, size).unwrap() > 200);
        let img = figure(title);
        assert_eq!(img.width(), 200);
        let top = img.height() - 100;
        assert!(
            top.is_multiple_of(line) && top / line >= 2,
            "title margin {top} px for lines of {line} px"
        );
        for i in 0..top / line {
            let band = (0, i * line, 200, (i + 1) * line);
            let (first, last) = ink_columns(&img, band);
            assert!(
                first > 0 && last < 199,
                "title line {i} cut: {first}–{last}"
            );
        }
        assert_eq!(*img.get_pixel(100, top), Rgb([0, 0, 0]), "panel moved");
        let word = "an_unbreakable_title_word_wider_than_the_panel";
        let img = figure(word);
        assert_eq!(img.width(), text_width(word, size).unwrap() + size);
        assert_eq!(img.height(), line + 100);
        let (first, last) = ink_columns(&img, (0, 0, img.width(), line));
        assert!(
            first > 0 && last < img.width() - 1,
            "title cut: {first}–{last}"
        );
        let rows = vec![vec![panel(100, 100, 0), panel(100, 100, 0)]];
        let heads = ["frame 12, t = 6.00 s · fixed step".to_string(), "b".into()];
        let labels = Labels {
            title: "",
            rows: &[],
            columns: &heads,
        };
        let img = grid(&rows, 4, &labels).unwrap();
        assert_eq!(img.width(), 204);
        let top = img.height() - 100;
        assert!(
            top.is_multiple_of(line) && top / line >= 2,
            "heading margin {top} px"
        );
        let (first, last) = ink_columns(&img, (0, 0, 104, top));
        assert!(first > 0 && last < 100, "long heading at {first}–{last}");
        assert_eq!(inked(&img, (100, 0, 204, top - line)), 0);
        assert!(inked(&img, (104, top - line, 204, top)) > 5, "heading b");
    }

    #[test]
    fn saved_figures_carry_their_labels_as_captions() {
        let dir = tempfile::tempdir().unwrap();
        let rows = vec![vec![panel(40, 40, 0), panel(40, 40, 9)]];
        let names = ["gridless".to_string()];
        let heads = [
            "frame 1, t = 0.05 s".to_string(),
            "frame 2, t = 0.1 s".to_string(),
        ];
        let labels = Labels {
            title: "06-3 slices",
            rows: &names,
            columns: &heads,
        };
        save(&dir.path().join("a.png"), &rows, 2, &labels).unwrap();
        save_row(&dir.path().join("b.png"), &rows[0], 2, "", &heads).unwrap();
        let captions = read_captions(&dir.path().join(CAPTIONS)).unwrap();
        assert_eq!(
            captions["a.png"],
            "06-3 slices. Rows, top to bottom: gridless. \
             Columns, left to right: frame 1, t = 0.05 s; frame 2, t = 0.1 s."
        );
        assert_eq!(
            captions["b.png"],
            "Columns, left to right: frame 1, t = 0.05 s; frame 2, t = 0.1 s."
        );
        assert!(dir.path().join("a.png").is_file() && dir.path().join("b.png").is_file());
    }

    #[test]
    fn label_counts_must_match() {
        let rows = vec![vec![panel(10, 10, 0)]];
        let two = ["a".to_string(), "b".to_string()];
        let bad = Labels {
            title: "",
            rows: &two,
            columns: &[],
        };
        assert!(grid(&rows, 0, &bad).is_err());
        assert!(grid(&[], 0, &Labels::default()).is_err());
    }
}
