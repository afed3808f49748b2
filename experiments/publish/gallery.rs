//! `smokelab gallery`: one static page, `results/index.html`, with every
//! experiment's figures, their captions and the command that made them.
//!
//! Nothing on the page is written by hand, so nothing can go stale: the
//! headings are the registry's (id, the figures of the notes reproduced,
//! title), the commands and commits come from each folder's
//! `manifest.json`, and a figure's caption is, in this order, the one its
//! experiment generated from the labels in its pixels (`figures.json`
//! beside it, [`crate::figures::panels::save`]), the manifest
//! entry that names it (a convergence study's observed order), or the alt
//! text `paper/paper.md` gives it. Each experiment's section is anchored by
//! its id (`index.html#06-5`); the captioned figures — those that reproduce
//! the notes — come first, and the rest (previews, single frames) are folded
//! away in a `<details>`. Links are relative, so the page opens from the
//! folder (or from a copy of it); the CSS is inline.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::Args;
use serde_json::Value;

use crate::experiment::kit::Experiment;
use crate::experiment::registry;
use smokelab::error::InputError;
use smokelab::io;

/// `smokelab gallery`.
#[derive(Debug, Args)]
pub struct GalleryArgs {
    /// The results folder to index; the page is written into it as
    /// `index.html` (default: the `results/` of the repository the working
    /// folder is in; outside one, give it).
    #[arg(long, value_name = "DIR")]
    pub results: Option<PathBuf>,
    /// Replace an earlier `index.html`.
    #[arg(long)]
    pub overwrite: bool,
}

/// Run `smokelab gallery`.
pub fn run(args: &GalleryArgs) -> Result<()> {
    let results = match &args.results {
        Some(dir) => dir.clone(),
        None => crate::run::output_dir::repository_root()?.join("results"),
    };
    let gallery = Gallery::scan(&results)?;
    let path = results.join("index.html");
    crate::run::output_dir::check_file(&path, "gallery", args.overwrite)?;
    let html = gallery.html();
    io::write_atomic(&path, |w| {
        use std::io::Write;
        Ok(w.write_all(html.as_bytes())?)
    })?;
    println!(
        "wrote {} ({} figures from {} folders)",
        path.display(),
        gallery.figure_count(),
        gallery.sections.len()
    );
    Ok(())
}

/// What one `manifest.json` says about how its folder was made.
#[derive(Clone, Debug, PartialEq)]
struct Provenance {
    /// The manifest read, relative to the results folder.
    source: PathBuf,
    command: String,
    commit: String,
    /// Captions for figures named by a manifest entry: file stem → text.
    captions: BTreeMap<String, String>,
}

impl Provenance {
    /// Read `results/dir/manifest.json`; `None` if there is none or it is
    /// not JSON.
    fn read(results: &Path, dir: &Path) -> Option<Self> {
        let source = dir.join("manifest.json");
        let text = std::fs::read_to_string(results.join(&source)).ok()?;
        let json: Value = serde_json::from_str(&text).ok()?;
        let field = |k: &str| json.get(k).and_then(Value::as_str).unwrap_or("").to_owned();
        Some(Self {
            source,
            command: shown_command(&field("command")),
            commit: field("commit"),
            captions: generated_captions(&results.join(dir))
                .into_iter()
                .chain(study_captions(json.get("extra")))
                .collect(),
        })
    }
}

/// A manifest's command line as a reader would type it: the program as
/// `smokelab` (not the path it ran from, `./target/release/smokelab`) and
/// the peers' Python as `PYTHON` (not the path it has on the machine that
/// made the results).
fn shown_command(command: &str) -> String {
    let mut words: Vec<String> = Vec::new();
    for word in command.split_whitespace() {
        let shown = if words.is_empty() && word.rsplit('/').next() == Some("smokelab") {
            "smokelab".to_owned()
        } else if words.last().is_some_and(|w| w == "--peers") {
            "PYTHON".to_owned()
        } else if word.starts_with("--peers=") {
            "--peers=PYTHON".to_owned()
        } else {
            word.to_owned()
        };
        words.push(shown);
    }
    words.join(" ")
}

/// The captions an experiment generated for the figures of `dir`
/// ([`crate::figures::panels::CAPTIONS`]), by file stem; none if the file is
/// missing or unreadable.
fn generated_captions(dir: &Path) -> BTreeMap<String, String> {
    let captions =
        crate::figures::panels::read_captions(&dir.join(crate::figures::panels::CAPTIONS))
            .unwrap_or_default();
    captions
        .into_iter()
        .filter_map(|(file, caption)| {
            let stem = Path::new(&file).file_stem()?.to_string_lossy().into_owned();
            Some((stem, caption))
        })
        .collect()
}

/// Captions from a manifest's `extra` when it is a list of studies, each
/// with a `study` name (its figure's file stem) and the observed order of
/// accuracy (the convergence experiment's manifest).
fn study_captions(extra: Option<&Value>) -> BTreeMap<String, String> {
    let Some(Value::Array(studies)) = extra else {
        return BTreeMap::new();
    };
    studies
        .iter()
        .filter_map(|s| {
            let name = s.get("study")?.as_str()?;
            let observed = s.get("observed")?.as_f64()?;
            let expected = s.get("expected")?.as_f64()?;
            let norm = s.get("norm").and_then(Value::as_str).unwrap_or("");
            let refined = s.get("refined").and_then(Value::as_str).unwrap_or("");
            let verdict = match s.get("pass").and_then(Value::as_bool) {
                Some(true) => ", passes",
                Some(false) => ", FAILS",
                None => "",
            };
            Some((
                name.to_owned(),
                format!(
                    "{name}: observed order {observed:.2} (expected {expected}) in the {norm} \
                     error, refining {refined}{verdict}"
                ),
            ))
        })
        .collect()
}

/// A figure: its image (PNG, else SVG) and every file of that stem.
#[derive(Debug)]
struct Figure {
    /// The image shown, relative to the results folder.
    shown: PathBuf,
    /// Every PNG/SVG of this stem (the shown one among them), linked.
    files: Vec<PathBuf>,
    /// The caption its experiment, its manifest or the paper gives it; a
    /// figure with none (a preview, a single frame) is folded away.
    caption: Option<String>,
}

/// The figures of one folder, with the manifest that made them.
#[derive(Debug)]
struct Group {
    /// The folder relative to the results folder.
    dir: PathBuf,
    provenance: Option<Provenance>,
    figures: Vec<Figure>,
}

/// One experiment's folder (or a folder the registry does not know).
#[derive(Debug)]
struct Section {
    /// The id (or folder name; `top` for figures at the top) in the page's
    /// table of contents, and the section's anchor.
    label: String,
    heading: String,
    /// `smokelab experiment <id>`, for registered experiments.
    rerun: Option<String>,
    groups: Vec<Group>,
}

/// Everything the page shows.
#[derive(Debug)]
struct Gallery {
    sections: Vec<Section>,
}

impl Gallery {
    /// Scan `results`: every PNG and SVG under it, grouped by experiment
    /// folder (the registry's order, then the others by name).
    ///
    /// # Errors
    /// An [`InputError`] if `results` is not a folder or holds no manifest.
    fn scan(results: &Path) -> Result<Self, InputError> {
        match std::fs::metadata(results) {
            Ok(m) if m.is_dir() => {}
            Ok(_) => {
                return Err(InputError::new(format!(
                    "results folder {} is not a folder; give the folder `smokelab experiment` writes into",
                    results.display()
                )))
            }
            Err(e) => {
                return Err(InputError::new(format!(
                    "results folder {} cannot be read ({e}); give the folder `smokelab experiment` writes into",
                    results.display()
                )))
            }
        }
        let mut files = Vec::new();
        let mut manifests = BTreeSet::new();
        walk(results, Path::new(""), &mut files, &mut manifests);
        if manifests.is_empty() {
            return Err(InputError::new(format!(
                "results folder {} holds no manifest.json; give the folder `smokelab experiment` writes into",
                results.display()
            )));
        }
        let captions = paper_captions(results);
        // Figures by top-level folder ("" for files at the top), then by
        // their own folder, then by stem.
        let mut tree: BTreeMap<String, BTreeMap<PathBuf, BTreeMap<String, Vec<PathBuf>>>> =
            BTreeMap::new();
        for f in files {
            let top = f
                .components()
                .next()
                .filter(|_| f.components().count() > 1)
                .map_or_else(String::new, |c| c.as_os_str().to_string_lossy().into());
            let dir = f.parent().unwrap_or(Path::new("")).to_path_buf();
            let stem = f.file_stem().unwrap_or_default().to_string_lossy().into();
            tree.entry(top)
                .or_default()
                .entry(dir)
                .or_default()
                .entry(stem)
                .or_default()
                .push(f);
        }
        let mut sections = Vec::new();
        for e in registry::ALL {
            if let Some(dirs) = tree.remove(e.folder) {
                let top = Top {
                    experiment: Some(e),
                    folder: e.folder,
                    manifests: &manifests,
                };
                sections.push(Section::new(results, &top, dirs, &captions));
            }
        }
        for (folder, dirs) in tree {
            let top = Top {
                experiment: None,
                folder: &folder,
                manifests: &manifests,
            };
            sections.push(Section::new(results, &top, dirs, &captions));
        }
        Ok(Self { sections })
    }

    fn figure_count(&self) -> usize {
        self.sections
            .iter()
            .flat_map(|s| &s.groups)
            .map(|g| g.figures.len())
            .sum()
    }

    /// The page.
    fn html(&self) -> String {
        let mut s = String::from(
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <title>smokelab results</title>\n<style>\n\
             body{font-family:system-ui,sans-serif;margin:1.5em;background:#fafafa;color:#222}\n\
             nav a{margin-right:.6em;white-space:nowrap}\n\
             section{margin-top:2em;border-top:1px solid #ccc}\n\
             .grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(320px,1fr));gap:1em}\n\
             figure{margin:0;background:#fff;border:1px solid #ddd;padding:.5em}\n\
             figure img{width:100%;height:auto;display:block;background:#fff}\n\
             figcaption{font-size:.85em;margin-top:.4em}\n\
             details{margin-top:1em}summary{cursor:pointer;color:#444}\n\
             code{background:#eee;padding:0 .2em;font-size:.85em;word-break:break-all}\n\
             .prov{font-size:.85em;color:#444}\n\
             </style>\n</head>\n<body>\n<h1>smokelab results</h1>\n<p>Every figure under this folder, \
             one section per experiment (anchored by its id, e.g. <code>#06-5</code>): first the \
             figures that reproduce the notes, with the captions their experiments generated, then, \
             folded away, the previews and single frames. Generated by <code>smokelab gallery</code> \
             from the registry and the manifests.</p>\n<nav>",
        );
        for sec in &self.sections {
            let _ = writeln!(
                s,
                "<a href=\"#{}\" title=\"{}\">{}</a>",
                href(Path::new(&sec.label)),
                escape(&sec.heading),
                escape(&sec.label)
            );
        }
        s.push_str("</nav>\n");
        for sec in &self.sections {
            let _ = writeln!(
                s,
                "<section id=\"{}\">\n<h2>{}</h2>",
                href(Path::new(&sec.label)),
                escape(&sec.heading)
            );
            if let Some(cmd) = &sec.rerun {
                let _ = writeln!(
                    s,
                    "<p class=\"prov\">rerun alone: <code>{}</code></p>",
                    escape(cmd)
                );
            }
            for g in &sec.groups {
                if g.dir.components().count() > 1 {
                    let _ = writeln!(s, "<h3>{}</h3>", escape(&g.dir.to_string_lossy()));
                }
                match &g.provenance {
                    Some(p) => {
                        let _ = writeln!(
                            s,
                            "<p class=\"prov\">made by <code>{}</code> at commit <code>{}</code> \
                             (<a href=\"{}\">{}</a>)</p>",
                            escape(&p.command),
                            escape(&p.commit),
                            href(&p.source),
                            escape(&p.source.to_string_lossy())
                        );
                    }
                    None => s.push_str(
                        "<p class=\"prov\">no manifest.json records how these were made</p>\n",
                    ),
                }
                let (captioned, previews): (Vec<&Figure>, Vec<&Figure>) =
                    g.figures.iter().partition(|f| f.caption.is_some());
                if !captioned.is_empty() {
                    figure_grid(&mut s, &captioned);
                }
                if !previews.is_empty() {
                    let _ = writeln!(
                        s,
                        "<details><summary>{} previews and frames</summary>",
                        previews.len()
                    );
                    figure_grid(&mut s, &previews);
                    s.push_str("</details>\n");
                }
            }
            s.push_str("</section>\n");
        }
        s.push_str("</body>\n</html>\n");
        s
    }
}

/// A grid of figures, each linked to its files, with its caption (if any)
/// above its path.
fn figure_grid(s: &mut String, figures: &[&Figure]) {
    s.push_str("<div class=\"grid\">\n");
    for f in figures {
        let links: Vec<String> = f
            .files
            .iter()
            .map(|p| {
                let ext = p.extension().unwrap_or_default().to_string_lossy();
                format!("<a href=\"{}\">{}</a>", href(p), escape(&ext))
            })
            .collect();
        let name = f.shown.to_string_lossy();
        let caption = f
            .caption
            .as_deref()
            .map_or_else(String::new, |c| format!("{}<br>", escape(c)));
        let _ = writeln!(
            s,
            "<figure><a href=\"{h}\"><img src=\"{h}\" alt=\"{a}\" loading=\"lazy\"></a>\
             <figcaption>{caption}<code>{n}</code> {l}</figcaption></figure>",
            h = href(&f.shown),
            a = escape(f.caption.as_deref().unwrap_or(&name)),
            n = escape(&name),
            l = links.join(" ")
        );
    }
    s.push_str("</div>\n");
}

/// A folder at the top of the results folder and what is known of it.
struct Top<'a> {
    /// The registered experiment writing into it, if any.
    experiment: Option<&'a Experiment>,
    /// Its name ("" for the results folder itself).
    folder: &'a str,
    /// Every folder under the results folder holding a manifest.
    manifests: &'a BTreeSet<PathBuf>,
}

impl Top<'_> {
    /// The manifest recording how the figures in `dir` were made: the
    /// folder's own, else the nearest above it inside this folder, else
    /// (an experiment that keeps one manifest per run, e.g. 06-6) the
    /// first of the runs' inside it.
    fn provenance(&self, results: &Path, dir: &Path) -> Option<Provenance> {
        let inside = |a: &Path| self.folder.is_empty() || a.starts_with(self.folder);
        dir.ancestors()
            .filter(|a| inside(a) && self.manifests.contains(*a))
            .chain(
                self.manifests
                    .iter()
                    .map(PathBuf::as_path)
                    .filter(|m| !self.folder.is_empty() && m.starts_with(self.folder)),
            )
            .find_map(|a| Provenance::read(results, a))
    }
}

impl Section {
    fn new(
        results: &Path,
        top: &Top,
        dirs: BTreeMap<PathBuf, BTreeMap<String, Vec<PathBuf>>>,
        paper: &BTreeMap<PathBuf, String>,
    ) -> Self {
        let (experiment, top_name) = (top.experiment, top.folder);
        let heading = match (experiment, top_name) {
            (Some(e), _) => format!("{} ({}): {}", e.id, e.reproduces, e.title),
            (None, "") => "figures at the top of the folder".to_owned(),
            (None, t) => format!("{t} (not an experiment of the registry)"),
        };
        let groups = dirs
            .into_iter()
            .map(|(dir, stems)| {
                let provenance = top.provenance(results, &dir);
                let figures = stems
                    .into_iter()
                    .map(|(stem, mut files)| {
                        files.sort_by_key(|p| !is_ext(p, "png"));
                        let shown = files[0].clone();
                        let caption = provenance
                            .as_ref()
                            .and_then(|p| p.captions.get(&stem).cloned())
                            .or_else(|| paper.get(&shown).cloned());
                        Figure {
                            shown,
                            files,
                            caption,
                        }
                    })
                    .collect();
                Group {
                    dir,
                    provenance,
                    figures,
                }
            })
            .collect();
        Self {
            label: match (experiment, top_name) {
                (Some(e), _) => e.id.to_owned(),
                (None, "") => "top".to_owned(),
                (None, t) => t.to_owned(),
            },
            heading,
            rerun: experiment.map(|e| format!("smokelab experiment {}", e.id)),
            groups,
        }
    }
}

/// Collect every PNG/SVG under `root/rel` (paths relative to `root`) and
/// the folders holding a `manifest.json`. Symbolic links are not followed.
fn walk(root: &Path, rel: &Path, files: &mut Vec<PathBuf>, manifests: &mut BTreeSet<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(root.join(rel)) else {
        return;
    };
    for entry in entries.flatten() {
        let Ok(kind) = entry.file_type() else {
            continue;
        };
        let path = rel.join(entry.file_name());
        if kind.is_dir() {
            walk(root, &path, files, manifests);
        } else if kind.is_file() {
            if entry.file_name() == "manifest.json" {
                manifests.insert(rel.to_path_buf());
            } else if is_ext(&path, "png") || is_ext(&path, "svg") {
                files.push(path);
            }
        }
    }
}

fn is_ext(path: &Path, ext: &str) -> bool {
    path.extension()
        .is_some_and(|e| e.to_string_lossy().eq_ignore_ascii_case(ext))
}

/// The alt texts `paper/paper.md` (next to the results folder) gives the
/// figures it shows, by path relative to the results folder.
fn paper_captions(results: &Path) -> BTreeMap<PathBuf, String> {
    let (Some(parent), Ok(results)) = (results.parent(), results.canonicalize()) else {
        return BTreeMap::new();
    };
    let paper = parent.join("paper");
    let Ok(text) = std::fs::read_to_string(paper.join("paper.md")) else {
        return BTreeMap::new();
    };
    let mut captions = BTreeMap::new();
    for piece in text.split("![").skip(1) {
        let Some((alt, rest)) = piece.split_once("](") else {
            continue;
        };
        let Some((target, _)) = rest.split_once(')') else {
            continue;
        };
        let Ok(full) = paper.join(target).canonicalize() else {
            continue;
        };
        if let Ok(rel) = full.strip_prefix(&results) {
            captions.insert(rel.to_path_buf(), alt.to_owned());
        }
    }
    captions
}

/// `text` with HTML's special characters escaped.
fn escape(text: &str) -> String {
    let mut s = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => s.push_str("&amp;"),
            '<' => s.push_str("&lt;"),
            '>' => s.push_str("&gt;"),
            '"' => s.push_str("&quot;"),
            '\'' => s.push_str("&#39;"),
            c => s.push(c),
        }
    }
    s
}

/// A relative URL for `path`: `/`-separated, bytes outside the unreserved
/// set percent-encoded.
fn href(path: &Path) -> String {
    let mut s = String::new();
    for (i, part) in path.components().enumerate() {
        if i > 0 {
            s.push('/');
        }
        for b in part.as_os_str().to_string_lossy().bytes() {
            if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
                s.push(b as char);
            } else {
                let _ = write!(s, "%{b:02X}");
            }
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_show_the_program_and_the_peers_python_by_name() {
        assert_eq!(
            shown_command(
                "./target/release/smokelab experiment all --publish --quiet --peers /work/.venv/bin/python"
            ),
            "smokelab experiment all --publish --quiet --peers PYTHON"
        );
        assert_eq!(
            shown_command("/usr/bin/smokelab experiment P-1 --peers=/x/python"),
            "smokelab experiment P-1 --peers=PYTHON"
        );
        assert_eq!(
            shown_command("smokelab run --out smokelab"),
            "smokelab run --out smokelab"
        );
    }

    #[test]
    fn links_are_relative_and_encoded() {
        assert_eq!(href(Path::new("06-1/a b#.png")), "06-1/a%20b%23.png");
        assert_eq!(escape("<a & \"b\">"), "&lt;a &amp; &quot;b&quot;&gt;");
    }

    #[test]
    fn studies_name_their_figures() {
        let extra = serde_json::json!([{"study": "sl_uniform_rk2", "observed": 1.96,
            "expected": 2.0, "norm": "rms", "refined": "Δx", "pass": true}]);
        let c = study_captions(Some(&extra));
        assert_eq!(
            c["sl_uniform_rk2"],
            "sl_uniform_rk2: observed order 1.96 (expected 2) in the rms error, refining Δx, passes"
        );
        assert!(study_captions(Some(&serde_json::json!({"a": 1}))).is_empty());
    }
}
