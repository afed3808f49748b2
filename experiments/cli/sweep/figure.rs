//! `sweep.png`, the figure across a sweep that `gather` writes beside
//! `sweep.csv`: a contact sheet with a panel per point, the point's last
//! saved preview (a scenario sweep) or its folder's main figure (an
//! experiment sweep, [`main_figure`]), in a grid whose columns are the
//! values of the last axis and whose rows are the combinations of the
//! others, each labelled `key = value` in the pixels
//! ([`crate::figures::panels`], which also records the caption in the
//! folder's `figures.json`). A point without an image (not complete, or no
//! figure found) is a grey panel, and `gather` says which.
//!
//! Beside it, `sweep_wall_seconds.png` and `.svg`: each point's wall time
//! against the first axis whose values are all numbers, a line per
//! combination of the other axes ([`wall_time_plot`]).

use std::path::{Path, PathBuf};

use anyhow::Result;
use image::{imageops, Rgb, RgbImage};

use super::plan::{plain, Plan, Point, State, Target};
use crate::figures::panels::{self, Labels};
use crate::figures::plot::{Plot, Series, Style};

/// The figure `gather` writes into the sweep's folder.
pub const SHEET: &str = "sweep.png";

/// The wall-time plot `gather` writes beside it (`.png` and `.svg`).
pub const WALL_PLOT: &str = "sweep_wall_seconds";

/// Pixels between panels.
const GAP: u32 = 6;

/// The panel of a point without an image.
const GREY: Rgb<u8> = Rgb([128, 128, 128]);

/// Around an image scaled into a panel of another shape.
const PAD: Rgb<u8> = Rgb([0, 0, 0]);

/// The last `preview_NNNN.png` in `folder` (the highest frame), if any.
fn last_preview(folder: &Path) -> Option<PathBuf> {
    let entries = std::fs::read_dir(folder).ok()?;
    entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .and_then(|n| n.strip_prefix("preview_")?.strip_suffix(".png"))
                .is_some_and(|frame| frame.bytes().all(|b| b.is_ascii_digit()))
        })
        .max()
}

/// The main figure of an experiment's `folder`: of the figures it
/// captioned in `figures.json` (else of its PNGs other than previews), the
/// only one, else `figure.png` if it is among them; none otherwise.
fn main_figure(folder: &Path) -> Option<PathBuf> {
    let captioned: Vec<PathBuf> = panels::read_captions(&folder.join(panels::CAPTIONS))
        .unwrap_or_default()
        .into_keys()
        .map(|name| folder.join(name))
        .filter(|p| p.is_file())
        .collect();
    let candidates = match captioned.is_empty() {
        false => captioned,
        true => std::fs::read_dir(folder)
            .ok()?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.extension().is_some_and(|e| e == "png")
                    && !p
                        .file_name()
                        .is_some_and(|n| n.to_string_lossy().starts_with("preview_"))
            })
            .collect(),
    };
    match candidates.as_slice() {
        [only] => Some(only.clone()),
        _ => candidates
            .into_iter()
            .find(|p| p.file_name().is_some_and(|n| n == "figure.png")),
    }
}

/// The image of `point` of the sweep `plan` in `dir`, or why it has none.
fn point_image(dir: &Path, plan: &Plan, point: &Point) -> Result<RgbImage, String> {
    if point.state != State::Complete {
        return Err(format!("it is {}", point.state));
    }
    let folder = dir.join(&point.folder);
    let path = match plan.target {
        Target::Scenario(_) => last_preview(&folder).ok_or("it saved no preview")?,
        Target::Experiment { .. } => main_figure(&folder)
            .ok_or("no main figure: its folder has no PNG, or several and no figure.png")?,
    };
    image::open(&path)
        .map(|i| i.to_rgb8())
        .map_err(|e| format!("cannot read {}: {e}", path.display()))
}

/// `img` scaled to fit `width` × `height`, keeping its shape, centred on
/// [`PAD`].
fn fit(img: &RgbImage, width: u32, height: u32) -> RgbImage {
    if img.dimensions() == (width, height) {
        return img.clone();
    }
    let scale = f64::min(
        f64::from(width) / f64::from(img.width()),
        f64::from(height) / f64::from(img.height()),
    );
    let w = ((f64::from(img.width()) * scale).round() as u32).clamp(1, width);
    let h = ((f64::from(img.height()) * scale).round() as u32).clamp(1, height);
    let scaled = imageops::resize(img, w, h, imageops::FilterType::Triangle);
    let mut out = RgbImage::from_pixel(width, height, PAD);
    imageops::replace(
        &mut out,
        &scaled,
        i64::from((width - w) / 2),
        i64::from((height - h) / 2),
    );
    out
}

/// `key = value` for each axis of `plan` in `range` at `point`, joined by
/// commas.
fn heading(plan: &Plan, point: &Point, range: std::ops::Range<usize>) -> String {
    plan.axes
        .iter()
        .zip(&point.values)
        .skip(range.start)
        .take(range.len())
        .map(|(axis, value)| format!("{} = {}", axis.key, plain(value)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The title: what the sweep runs and its folder's name.
fn title(dir: &Path, plan: &Plan) -> String {
    let folder = dir
        .file_name()
        .map_or_else(|| dir.display().to_string(), |n| n.to_string_lossy().into());
    match &plan.target {
        Target::Scenario(kind) => {
            let name = clap::ValueEnum::to_possible_value(kind)
                .map_or_else(|| format!("{kind:?}"), |v| v.get_name().to_string());
            format!("{name} sweep {folder}")
        }
        Target::Experiment { size, .. } => format!("experiment sweep {folder} ({size} size)"),
    }
}

/// Write `DIR/sweep.png` for the sweep `plan` (its points' states fresh),
/// printing which points have a grey panel and why; no figure, and a line
/// saying so, if no point has an image.
pub fn contact_sheet(dir: &Path, plan: &Plan) -> Result<()> {
    let images: Vec<Option<RgbImage>> = plan
        .points
        .iter()
        .map(|p| match point_image(dir, plan, p) {
            Ok(img) => Some(img),
            Err(why) => {
                println!(
                    "{SHEET}: point {} ({}) is a grey panel: {why}",
                    p.index,
                    plan.describe(p)
                );
                None
            }
        })
        .collect();
    let found = images.iter().flatten();
    let Some(width) = found.clone().map(RgbImage::width).max() else {
        println!("wrote no {SHEET}: no point has an image to show");
        return Ok(());
    };
    let height = found.map(RgbImage::height).max().unwrap_or(width);
    let panels: Vec<RgbImage> = images
        .iter()
        .map(|img| match img {
            Some(img) => fit(img, width, height),
            None => RgbImage::from_pixel(width, height, GREY),
        })
        .collect();
    // The last axis varies fastest: a row per run of its values.
    let axes = plan.axes.len();
    let columns = plan.axes.last().map_or(1, |a| a.values.len().max(1));
    let rows: Vec<Vec<RgbImage>> = panels.chunks(columns).map(<[_]>::to_vec).collect();
    let column_labels: Vec<String> = plan
        .points
        .iter()
        .take(columns)
        .map(|p| heading(plan, p, axes.saturating_sub(1)..axes))
        .collect();
    let row_labels: Vec<String> = match axes > 1 {
        true => plan
            .points
            .iter()
            .step_by(columns)
            .map(|p| heading(plan, p, 0..axes - 1))
            .collect(),
        false => Vec::new(),
    };
    let title = title(dir, plan);
    let path = dir.join(SHEET);
    let labels = Labels {
        title: &title,
        rows: &row_labels,
        columns: &column_labels,
    };
    panels::save(&path, &rows, GAP, &labels)?;
    println!("wrote {}", path.display());
    Ok(())
}

/// Write `DIR/sweep_wall_seconds.png` and `.svg`: `wall[i]`, point `i`'s
/// wall time in seconds (none for a point without one), against the first
/// axis of `plan` whose values are all numbers, a line per combination of
/// the other axes; no plot, and a line saying so, without such an axis or
/// any wall time.
pub fn wall_time_plot(dir: &Path, plan: &Plan, wall: &[Option<f64>]) -> Result<()> {
    let axes = plan.axes.len();
    let Some(x_axis) = plan
        .axes
        .iter()
        .position(|a| a.values.iter().all(serde_json::Value::is_number))
    else {
        println!("wrote no {WALL_PLOT}.png: no axis of numbers to plot against");
        return Ok(());
    };
    // A series per combination of the other axes, in the points' order
    // (so each keeps its colour as more points complete).
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for (point, seconds) in plan.points.iter().zip(wall) {
        let name = [
            heading(plan, point, 0..x_axis),
            heading(plan, point, x_axis + 1..axes),
        ]
        .into_iter()
        .filter(|h| !h.is_empty())
        .collect::<Vec<_>>()
        .join(", ");
        let i = match series.iter().position(|(n, _)| *n == name) {
            Some(i) => i,
            None => {
                series.push((name, Vec::new()));
                series.len() - 1
            }
        };
        let x = point.values.get(x_axis).and_then(serde_json::Value::as_f64);
        if let (Some(x), Some(y)) = (x, *seconds) {
            series[i].1.push((x, y));
        }
    }
    series.retain(|(_, points)| !points.is_empty());
    if series.is_empty() {
        println!("wrote no {WALL_PLOT}.png: no point recorded its wall time");
        return Ok(());
    }
    let mut plot = Plot::new(
        format!("{}: wall time", title(dir, plan)),
        plan.axes[x_axis].key.as_str(),
        "wall time (s)",
    );
    for (name, points) in series {
        let name = if name.is_empty() {
            "wall time".into()
        } else {
            name
        };
        plot = plot.series(Series::line(name, points).styled(Style::LineMarkers));
    }
    let [png, svg] = plot.write(&dir.join(WALL_PLOT))?;
    println!("wrote {} and {}", png.display(), svg.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_keeps_the_shape_and_centres_the_image() {
        let img = RgbImage::from_pixel(10, 5, Rgb([255, 0, 0]));
        let out = fit(&img, 40, 40);
        assert_eq!(out.dimensions(), (40, 40));
        // Scaled to 40 × 20, with 10 rows of padding above and below.
        assert_eq!(*out.get_pixel(20, 20), Rgb([255, 0, 0]));
        assert_eq!(*out.get_pixel(20, 5), PAD);
        assert_eq!(*out.get_pixel(20, 34), PAD);
        assert_eq!(fit(&img, 10, 5), img);
    }

    #[test]
    fn the_main_figure_is_the_only_one_or_figure_png() {
        let dir = tempfile::tempdir().unwrap();
        let write = |name: &str| std::fs::write(dir.path().join(name), b"").unwrap();
        assert_eq!(main_figure(dir.path()), None);
        write("preview_0001.png");
        write("a.png");
        assert_eq!(main_figure(dir.path()), Some(dir.path().join("a.png")));
        write("b.png");
        assert_eq!(main_figure(dir.path()), None);
        write("figure.png");
        assert_eq!(main_figure(dir.path()), Some(dir.path().join("figure.png")));
        // A captioned figure is the main one among the folder's PNGs.
        std::fs::write(dir.path().join(panels::CAPTIONS), r#"{"b.png": "B."}"#).unwrap();
        assert_eq!(main_figure(dir.path()), Some(dir.path().join("b.png")));
        assert_eq!(
            last_preview(dir.path()),
            Some(dir.path().join("preview_0001.png"))
        );
    }
}
