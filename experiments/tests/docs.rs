//! The documentation stays true to the code: the book's generated pages (the
//! command-line reference from clap, the experiments catalogue from the
//! registry) equal what the code generates now, and every relative link in
//! the book and the README points at a file that exists (and, with
//! `#anchor`, at a heading of it).
//!
//! Refresh the generated pages with
//! `SMOKELAB_BLESS=1 cargo test --release -p smokelab-app --test docs`.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use clap::CommandFactory;
use smokelab_app::cli::Cli;
use smokelab_app::experiment::registry;

/// The repository root (the workspace, one above the app crate).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// `docs/src/reference/cli.md`: every subcommand and option, from clap.
fn cli_reference() -> String {
    let options = clap_markdown::MarkdownOptions::new()
        .title("Command-line reference".into())
        .show_footer(false);
    let body = clap_markdown::help_markdown_custom::<Cli>(&options);
    let note = "<!-- Generated from the clap definitions in experiments/cli/ and \
                src/scenario/config.rs by experiments/tests/docs.rs; do not edit. -->\n\n";
    format!("{note}{body}")
}

/// `docs/src/reference/experiments.md`: the registry as a table.
fn experiments_catalogue() -> String {
    let mut s = String::from(
        "<!-- Generated from experiments/experiment/registry.rs by experiments/tests/docs.rs; do not edit. -->\n\n\
         # Experiments catalogue\n\n\
         Every numbered experiment, in the notes' order. Run one with \
         `smokelab experiment <id>`; it writes a new folder `runs/<id>-<time>/` \
         at the default size (`--smoke`: seconds, `--full`: the notes' sizes; \
         `--publish`: into the committed `results/<id>/`). The time is the default run's on two cores; *seconds* or \
         *minutes* is its class. The gallery, `results/index.html` in the \
         repository, shows each one's figures under the same id.\n\n\
         | id | reproduces | what it shows | default run | class |\n\
         |---|---|---|---|---|\n",
    );
    for e in registry::ALL {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} |\n",
            e.id,
            e.reproduces,
            e.title.replace('|', "\\|"),
            e.cost,
            class(e.cost)
        ));
    }
    s
}

/// *minutes* for a default run that takes a minute or more, else *seconds*.
fn class(cost: &str) -> &'static str {
    let long = cost.contains("min")
        || cost
            .split_whitespace()
            .filter_map(seconds)
            .any(|t| t >= 60.0);
    if long {
        "minutes"
    } else {
        "seconds"
    }
}

/// A cost given in plain seconds (`"204"` of `"204 s"`), if this word is one.
fn seconds(word: &str) -> Option<f64> {
    word.trim_start_matches('~').parse().ok()
}

/// Compare a generated page with its committed copy; with `SMOKELAB_BLESS=1`
/// write it instead.
fn check_generated(relative: &str, generated: &str) {
    let path = root().join(relative);
    if std::env::var_os("SMOKELAB_BLESS").is_some() {
        std::fs::write(&path, generated).unwrap();
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    if committed != generated {
        let line = committed
            .lines()
            .zip(generated.lines())
            .position(|(a, b)| a != b)
            .map_or(
                committed.lines().count().min(generated.lines().count()),
                |i| i,
            )
            + 1;
        panic!(
            "{relative} is stale (first difference at line {line}); refresh it with \
             `SMOKELAB_BLESS=1 cargo test --release -p smokelab-app --test docs` and commit it"
        );
    }
}

#[test]
fn cli_reference_is_current() {
    // The command line must be valid clap before it is documented.
    Cli::command().debug_assert();
    check_generated("docs/src/reference/cli.md", &cli_reference());
}

#[test]
fn experiments_catalogue_is_current() {
    check_generated(
        "docs/src/reference/experiments.md",
        &experiments_catalogue(),
    );
}

/// The anchor mdBook and GitHub give a heading: lower case, spaces to `-`,
/// punctuation dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The lines of a Markdown text outside fenced code blocks.
fn prose_lines(text: &str) -> impl Iterator<Item = &str> {
    let mut in_code = false;
    text.lines().filter(move |line| {
        if line.trim_start().starts_with("```") {
            in_code = !in_code;
            return false;
        }
        !in_code
    })
}

/// The anchors of a Markdown file: its headings' slugs (outside code blocks)
/// and explicit `id="…"` attributes.
fn anchors(text: &str) -> BTreeSet<String> {
    let mut set = BTreeSet::new();
    for line in prose_lines(text) {
        if let Some(h) = line.strip_prefix('#') {
            let title = h.trim_start_matches('#');
            if title.starts_with(' ') {
                set.insert(slug(title));
            }
        }
        for part in line.split("id=\"").skip(1) {
            if let Some(end) = part.find('"') {
                set.insert(part[..end].to_string());
            }
        }
    }
    set
}

/// The targets of the Markdown links `](target)` and mdBook includes
/// `{{#include target}}` of a file, outside code blocks.
fn links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in prose_lines(text) {
        for part in line.split("](").skip(1) {
            if let Some(end) = part.find(')') {
                let target = part[..end].split_whitespace().next().unwrap_or("");
                out.push(target.to_string());
            }
        }
        for part in line.split("{{#include ").skip(1) {
            if let Some(end) = part.find("}}") {
                out.push(part[..end].trim().to_string());
            }
        }
    }
    out
}

/// Every Markdown file of the book, and the README.
fn documents() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "md") {
                out.push(path);
            }
        }
    }
    let mut docs = vec![root().join("README.md")];
    walk(&root().join("docs/src"), &mut docs);
    docs.sort();
    docs
}

#[test]
fn relative_links_resolve() {
    let mut broken = Vec::new();
    let docs = documents();
    assert!(docs.len() > 5, "the book has pages: {docs:?}");
    for doc in &docs {
        let text = std::fs::read_to_string(doc).unwrap();
        for target in links(&text) {
            if target.is_empty() || target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (file, anchor) = match target.split_once('#') {
                Some((f, a)) => (f, Some(a)),
                None => (target.as_str(), None),
            };
            // An include may name a line range: `file.md:3:10`.
            let file = file.split(':').next().unwrap_or(file);
            let path = if file.is_empty() {
                doc.clone()
            } else {
                doc.parent().unwrap().join(file)
            };
            let shown = format!("{}: {target}", doc.strip_prefix(root()).unwrap().display());
            if !path.exists() {
                broken.push(format!("{shown} (no such file)"));
                continue;
            }
            let is_markdown = path.extension().is_some_and(|e| e == "md");
            if let (Some(anchor), true) = (anchor, is_markdown) {
                let text = std::fs::read_to_string(&path).unwrap();
                if !anchors(&text).contains(anchor) {
                    broken.push(format!("{shown} (no heading with anchor #{anchor})"));
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn link_checker_catches_a_broken_link() {
    // The checker itself: a heading's slug and a link it must reject.
    assert_eq!(slug(" Outputs and conventions"), "outputs-and-conventions");
    assert_eq!(slug(" VDB in Blender & Houdini"), "vdb-in-blender--houdini");
    let text =
        "# Top\n```\n# not a heading\n[x](nowhere.md)\n```\n[a](b.md#top) {{#include c.md}}\n";
    assert_eq!(links(text), vec!["b.md#top", "c.md"]);
    assert!(anchors(text).contains("top"));
    assert!(!anchors(text).contains("not-a-heading"));
}

/// The relative `href="…"` and `src="…"` targets of an HTML page, without
/// their `#anchor` or `?query`; links with a scheme, site-absolute ones
/// (`/…`) and bare anchors left out.
fn html_targets(page: &str) -> Vec<String> {
    let mut out = Vec::new();
    for attr in ["href=\"", "src=\""] {
        for part in page.split(attr).skip(1) {
            let Some(end) = part.find('"') else { continue };
            let target = part[..end].replace("&amp;", "&");
            // `/…` is relative to where the book is served (the 404 page's
            // base), not a file of it.
            let is_external = target.starts_with('/')
                || target
                    .split_once(':')
                    .is_some_and(|(scheme, _)| scheme.chars().all(|c| c.is_ascii_alphabetic()));
            let path = target.split(['#', '?']).next().unwrap_or("");
            if !is_external && !path.is_empty() {
                out.push(path.to_string());
            }
        }
    }
    out
}

/// The built book (mdBook's HTML, not the Markdown) links only to files in
/// the book: a link out of it (to `paper/paper.html`, which exists only
/// after `smokelab paper` with pandoc, or to `results/`) is dead where the
/// book is served (`mdbook serve`) or published. Skipped, saying so, where
/// mdbook is not installed (`.ci/run` installs it first).
#[test]
fn built_book_has_no_dead_links() {
    let Ok(version) = std::process::Command::new("mdbook")
        .arg("--version")
        .output()
    else {
        eprintln!("skipped: mdbook is not installed (cargo install mdbook --locked)");
        return;
    };
    assert!(version.status.success());
    let out = tempfile::tempdir().unwrap();
    let built = std::process::Command::new("mdbook")
        .arg("build")
        .arg(root().join("docs"))
        .arg("--dest-dir")
        .arg(out.path())
        .output()
        .unwrap();
    assert!(
        built.status.success(),
        "mdbook build: {}",
        String::from_utf8_lossy(&built.stderr)
    );
    fn pages(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                pages(&path, out);
            } else if path.extension().is_some_and(|e| e == "html") {
                out.push(path);
            }
        }
    }
    let mut html = Vec::new();
    pages(out.path(), &mut html);
    assert!(html.len() > 10, "the built book has pages: {html:?}");
    let mut dead = BTreeSet::new();
    for page in &html {
        let text = std::fs::read_to_string(page).unwrap();
        for target in html_targets(&text) {
            let path = page.parent().unwrap().join(&target);
            let inside = path
                .canonicalize()
                .is_ok_and(|p| p.starts_with(out.path().canonicalize().unwrap()));
            if !inside {
                let shown = page.strip_prefix(out.path()).unwrap().display();
                dead.insert(format!("{shown}: {target}"));
            }
        }
    }
    assert!(
        dead.is_empty(),
        "dead links in the built book:\n{}",
        dead.into_iter().collect::<Vec<_>>().join("\n")
    );
    // The checker itself: a link out of the book and a missing page are dead.
    assert_eq!(
        html_targets(
            r##"<a href="../../paper/paper.html#x">p</a> <img src="a.png"> <a href="https://x.org/">x</a> <a href="#top">t</a>"##
        ),
        ["../../paper/paper.html", "a.png"]
    );
}
