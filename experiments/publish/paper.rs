//! `smokelab paper`: keep `paper/paper.md` in step with `results/` and build
//! it to HTML.
//!
//! The Markdown is the source. Blocks between `<!-- name:begin -->` and
//! `<!-- name:end -->` markers are copied from files the experiments write
//! (the convergence orders table from `results/convergence/orders.md`; the
//! claims table measured from the results by [`crate::publish::claims`]), and the
//! numbers of the prose are read from the results files they name
//! ([`crate::publish::paper_values`]), so
//! re-running an experiment with `--publish` and then `smokelab paper`
//! updates the paper.
//! If `pandoc` is on the PATH the paper is also written to
//! `paper/paper.html`; without it the command says so and succeeds. An
//! earlier `paper.html` is replaced only with `--overwrite` (the output
//! rule, [`crate::run::output_dir`]).
//!
//! The repository is the nearest folder at or above the working folder
//! holding `paper/paper.md`, or `--root DIR`; never the checkout the
//! binary was built from, which would be written behind the user's back.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context, Result};
use clap::Args;

use smokelab::error::InputError;
use smokelab::io;

/// Replace the text between `<!-- {name}:begin -->` and `<!-- {name}:end -->`
/// in `doc` with `content`.
///
/// # Errors
/// If the markers are missing or out of order.
pub fn replace_block(doc: &str, name: &str, content: &str) -> Result<String> {
    let (begin, end) = (
        format!("<!-- {name}:begin -->"),
        format!("<!-- {name}:end -->"),
    );
    let (Some(b), Some(e)) = (doc.find(&begin), doc.find(&end)) else {
        bail!("paper has no {begin} … {end} block");
    };
    if e < b {
        bail!("paper's {end} comes before {begin}");
    }
    let start = b + begin.len();
    Ok(format!(
        "{}\n{}\n{}",
        &doc[..start],
        content.trim_end(),
        &doc[e..]
    ))
}

/// `smokelab paper`.
#[derive(Debug, Default, Args)]
pub struct PaperArgs {
    /// The repository: the folder holding `paper/paper.md` and `results/`
    /// (default: the nearest such folder at or above the working folder).
    #[arg(long, value_name = "DIR")]
    pub root: Option<PathBuf>,
    /// Replace an earlier `paper/paper.html`.
    #[arg(long)]
    pub overwrite: bool,
}

/// Run `smokelab paper`.
pub fn run(args: &PaperArgs) -> Result<()> {
    let root = match &args.root {
        Some(r) if r.join("paper/paper.md").is_file() => r.clone(),
        Some(r) => {
            return Err(InputError::new(format!(
                "--root {}: it holds no paper/paper.md; give the repository's folder",
                r.display()
            ))
            .into())
        }
        None => crate::run::output_dir::repository_root()?,
    };
    crate::run::output_dir::check_file(&root.join("paper/paper.html"), "paper", args.overwrite)?;
    build(&root)
}

/// The paper's performance section from experiment P-1's `table.md` and
/// manifest in `perf` (`results/perf`): what was timed, the machine's load
/// before and after, and the table.
///
/// # Errors
/// A missing or unreadable table or manifest.
fn performance(perf: &Path) -> Result<String> {
    let table = std::fs::read_to_string(perf.join("table.md"))
        .with_context(|| format!("cannot read {}/table.md", perf.display()))?;
    let manifest: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(perf.join("manifest.json"))
            .with_context(|| format!("cannot read {}/manifest.json", perf.display()))?,
    )
    .with_context(|| format!("{}/manifest.json is not JSON", perf.display()))?;
    let extra = &manifest["extra"];
    let load = |k: &str| load_average(extra[k].as_str());
    let peers = if extra["peers"].is_object() {
        "Peer: Taichi's fused semi-Lagrangian advection of five fields (Euler \
         backtrace) plus three pyFFTW f32 pairs, run right before and right \
         after smokelab at each size (the mean of the two) and compared with \
         smokelab's Euler step."
    } else {
        "The peers were not run (`--peers PYTHON` adds them)."
    };
    Ok(format!(
        "One hot/cold step (gridded, semi-Lagrangian RK2, inviscid: advection of \
         the three face components and both gases, buoyancy, the pressure \
         solve) on the 2-core machine, f32, medians of experiment P-1 \
         (`smokelab experiment P-1`, `results/perf/`; this block is written by \
         `smokelab paper` from `results/perf/table.md`). Times in ms; stages \
         are the step's own timers; the floor is one FFT pair plus a memory \
         pass over the five fields; speed-up is 2 threads over 1, with the \
         fields bitwise equal. {peers} Load average (1, 5, 15 min) before the \
         run: {}; after: {}.\n\n{table}",
        load("load_before"),
        load("load_after"),
    ))
}

/// The 1-, 5- and 15-minute load averages of a recorded `/proc/loadavg` line
/// (`"2.35 2.37 3.79 1/84 7355"` → `"2.35, 2.37, 3.79"`); `unrecorded`
/// without one.
fn load_average(line: Option<&str>) -> String {
    let fields: Vec<&str> = line.unwrap_or("").split_whitespace().take(3).collect();
    if fields.len() == 3 {
        fields.join(", ")
    } else {
        "unrecorded".into()
    }
}

/// `doc` (the Markdown at `md`) with the alt text of every image whose
/// folder has a generated caption for it ([`crate::figures::panels::CAPTIONS`])
/// replaced by that caption, so that the paper describes each labelled
/// figure as its pixels do.
///
/// # Errors
/// A captions file that is not a map of strings.
pub fn generated_alt_texts(doc: &str, md: &Path) -> Result<String> {
    let base = md.parent().unwrap_or(Path::new("."));
    let mut out = String::with_capacity(doc.len());
    let mut rest = doc;
    while let Some(at) = rest.find("![") {
        out.push_str(&rest[..at]);
        let image = &rest[at..];
        let parsed = image[2..].split_once("](").and_then(|(alt, tail)| {
            let (target, _) = tail.split_once(')')?;
            (!alt.contains('\n')).then_some((alt, target))
        });
        let Some((alt, target)) = parsed else {
            out.push_str("![");
            rest = &image[2..];
            continue;
        };
        let path = base.join(target);
        let file = path.file_name().map(|f| f.to_string_lossy().into_owned());
        let captions = crate::figures::panels::read_captions(
            &path.with_file_name(crate::figures::panels::CAPTIONS),
        )?;
        let text = file
            .and_then(|f| captions.get(&f).cloned())
            .map(|c| c.replace(['[', ']'], ""))
            .unwrap_or_else(|| alt.to_string());
        out.push_str(&format!("![{text}]({target})"));
        rest = &image[2 + alt.len() + 2 + target.len() + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

/// Refresh the generated blocks of `root/paper/paper.md` and, if pandoc is
/// installed, write `root/paper/paper.html`.
///
/// # Errors
/// Missing paper or results files, or a failing pandoc.
pub fn build(root: &Path) -> Result<()> {
    let md = root.join("paper/paper.md");
    let doc = refreshed(root)?;
    io::write_atomic(&md, |w| {
        use std::io::Write;
        Ok(w.write_all(doc.as_bytes())?)
    })?;
    println!("refreshed {}", md.display());
    let html = root.join("paper/paper.html");
    match Command::new("pandoc")
        .arg(&md)
        .args(["--standalone", "--mathml", "--metadata"])
        // `pagetitle` names the page without a second title above the
        // paper's own heading.
        .arg("pagetitle=smokelab: resolution-independent smoke, reproduced")
        .arg(format!("--variable=header-includes:{HTML_STYLE}"))
        .arg("-o")
        .arg(&html)
        .current_dir(md.parent().unwrap_or(root))
        .status()
    {
        Ok(s) if s.success() => println!("wrote {}", html.display()),
        Ok(s) => bail!("pandoc failed ({s}) building {}", html.display()),
        Err(_) => println!("pandoc not found: the Markdown is the paper; install pandoc for HTML"),
    }
    Ok(())
}

/// Style added to the HTML page: wide tables scroll sideways instead of
/// being clipped by the page's column, and images fit it.
const HTML_STYLE: &str = "<style>table { display: block; overflow-x: auto; max-width: 100%; } \
                          img { max-width: 100%; height: auto; }</style>";

/// What fills the paper's `validation` block: experiment V-1's
/// `table.md`, or while V-1 has not run, the command that makes it.
///
/// # Errors
/// A `table.md` that exists but cannot be read.
fn validation(results: &Path) -> Result<String> {
    let table = results.join("validation/table.md");
    if !table.exists() {
        return Ok(
            "*Not run yet: `smokelab experiment V-1 --publish`, then `smokelab paper --overwrite`.*".into(),
        );
    }
    std::fs::read_to_string(&table).with_context(|| format!("cannot read {}", table.display()))
}

/// `root/paper/paper.md` with its generated blocks and alt texts refreshed
/// from `root/results/`: what `smokelab paper` writes.
///
/// # Errors
/// Missing paper or results files.
pub fn refreshed(root: &Path) -> Result<String> {
    let md = root.join("paper/paper.md");
    let mut doc =
        std::fs::read_to_string(&md).with_context(|| format!("cannot read {}", md.display()))?;
    let orders = root.join("results/convergence/orders.md");
    let table = std::fs::read_to_string(&orders).with_context(|| {
        format!(
            "cannot read {} (run `smokelab experiment C-1`)",
            orders.display()
        )
    })?;
    doc = replace_block(&doc, "orders", &table)?;
    doc = generated_alt_texts(&doc, &md)?;
    let perf = root.join("results/perf");
    if perf.join("table.md").exists() && doc.contains("<!-- performance:begin -->") {
        doc = replace_block(&doc, "performance", &performance(&perf)?)?;
    }
    if doc.contains("<!-- validation:begin -->") {
        doc = replace_block(&doc, "validation", &validation(&root.join("results"))?)?;
    }
    if doc.contains("<!-- claims:begin -->") {
        doc = replace_block(
            &doc,
            "claims",
            &crate::publish::claims::table(&root.join("results"))?,
        )?;
    }
    crate::publish::paper_values::fill(&doc, &root.join("results"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn load_average_keeps_the_three_averages() {
        assert_eq!(
            load_average(Some("2.35 2.37 3.79 1/84 7355")),
            "2.35, 2.37, 3.79"
        );
        assert_eq!(load_average(Some("2.35")), "unrecorded");
        assert_eq!(load_average(None), "unrecorded");
    }

    #[test]
    fn alt_texts_come_from_generated_captions() {
        let dir = tempfile::tempdir().unwrap();
        let (paper, fig) = (dir.path().join("paper"), dir.path().join("results/06-1"));
        std::fs::create_dir_all(&paper).unwrap();
        std::fs::create_dir_all(&fig).unwrap();
        std::fs::write(
            fig.join(crate::figures::panels::CAPTIONS),
            r#"{"a.png": "Rows: [x]; y."}"#,
        )
        .unwrap();
        let doc = "t ![old](../results/06-1/a.png) u ![kept](../results/06-1/b.png) ![](x.png)\n";
        let out = generated_alt_texts(doc, &paper.join("paper.md")).unwrap();
        assert_eq!(
            out,
            "t ![Rows: x; y.](../results/06-1/a.png) u ![kept](../results/06-1/b.png) ![](x.png)\n"
        );
    }

    #[test]
    fn replaces_only_the_named_block() {
        let doc = "a\n<!-- t:begin -->\nold\n<!-- t:end -->\nb\n";
        let out = replace_block(doc, "t", "new\n").unwrap();
        assert_eq!(out, "a\n<!-- t:begin -->\nnew\n<!-- t:end -->\nb\n");
        assert!(replace_block(doc, "missing", "x").is_err());
        assert!(replace_block("<!-- t:end --><!-- t:begin -->", "t", "x").is_err());
    }

    #[test]
    fn performance_block_carries_p1_table_load_and_peers() {
        let dir = tempfile::tempdir().unwrap();
        assert!(performance(dir.path()).is_err(), "no table, no block");
        std::fs::write(dir.path().join("table.md"), "| res |\n|---|\n| 32³ |\n").unwrap();
        let manifest = |peers: serde_json::Value| {
            let m = serde_json::json!({"extra": {
                "load_before": "0.31 0.40 0.52 1/200 7",
                "load_after": "1.90 0.80 0.60 2/200 9",
                "peers": peers,
            }});
            std::fs::write(dir.path().join("manifest.json"), m.to_string()).unwrap();
        };
        manifest(serde_json::json!("absent: run with --peers PYTHON"));
        let text = performance(dir.path()).unwrap();
        assert!(text.ends_with("| res |\n|---|\n| 32³ |\n"), "{text}");
        assert!(text.contains("before the run: 0.31, 0.40, 0.52; after: 1.90, 0.80, 0.60."));
        assert!(text.contains("were not run"));
        manifest(serde_json::json!({"python": "/x/python"}));
        assert!(performance(dir.path()).unwrap().contains("Taichi's fused"));
    }
}
