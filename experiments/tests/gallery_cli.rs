//! `smokelab gallery`: the page links every figure under the results folder,
//! names every manifest's command, links only files that exist, and refuses
//! a folder that is missing or holds no manifest.

mod common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use common::{assert_ok, smokelab, Sandbox};
use smokelab_app::experiment::registry;

/// Every PNG/SVG under `root`, relative to it, `/`-separated.
fn figures(root: &Path) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut stack = vec![PathBuf::new()];
    while let Some(rel) = stack.pop() {
        for e in std::fs::read_dir(root.join(&rel)).unwrap() {
            let e = e.unwrap();
            let path = rel.join(e.file_name());
            if e.file_type().unwrap().is_dir() {
                stack.push(path);
            } else if matches!(
                path.extension().and_then(|x| x.to_str()),
                Some("png" | "svg")
            ) {
                out.insert(path.to_string_lossy().replace('\\', "/"));
            }
        }
    }
    out
}

/// The values of every `href="…"` and `src="…"` in `html`.
fn links(html: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for attr in ["href=\"", "src=\""] {
        for piece in html.split(attr).skip(1) {
            out.insert(piece.split('"').next().unwrap().to_owned());
        }
    }
    out
}

/// Copy the folder `from` into `to`, recursively.
fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_dir() {
            copy_tree(&e.path(), &to.join(e.file_name()));
        } else {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

/// Run `smokelab gallery --results DIR`, check it succeeded and return the
/// page.
fn gallery(results: &Path) -> String {
    let args = ["gallery", "--results", results.to_str().unwrap()];
    assert_ok(&smokelab(&args, results), &args);
    std::fs::read_to_string(results.join("index.html")).unwrap()
}

/// Check that every local link of `html` names a file under `results`.
fn assert_links_exist(html: &str, results: &Path) {
    for l in links(html).iter().filter(|l| !l.starts_with('#')) {
        let path = results.join(l.replace("%20", " "));
        assert!(path.is_file(), "the page links {l}, which does not exist");
    }
}

fn write_png(path: &Path) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    image::RgbImage::from_pixel(4, 3, image::Rgb([200, 10, 10]))
        .save(path)
        .unwrap();
}

/// An empty SVG image.
const SVG: &str = "<svg xmlns=\"http://www.w3.org/2000/svg\"/>";

fn write_manifest(dir: &Path, command: &str, commit: &str) {
    std::fs::create_dir_all(dir).unwrap();
    let m = serde_json::json!({"status": "complete", "command": command, "commit": commit});
    std::fs::write(dir.join("manifest.json"), m.to_string()).unwrap();
}

#[test]
fn a_small_results_tree_is_shown_whole() {
    let tmp = tempfile::tempdir().unwrap();
    let results = tmp.path();
    // A registered experiment with a figure and its SVG twin, and a folder
    // the registry does not know with a run sub-folder.
    write_manifest(
        &results.join("06-1"),
        "smokelab experiment 06-1 --out x",
        "c0ffee1",
    );
    write_png(&results.join("06-1/sequence.png"));
    std::fs::write(results.join("06-1/sequence.svg"), SVG).unwrap();
    std::fs::write(
        results.join("06-1/figures.json"),
        r#"{"sequence.png": "Rows: passing; head-on."}"#,
    )
    .unwrap();
    write_png(&results.join("06-1/preview_0001.png"));
    write_manifest(
        &results.join("extra"),
        "smokelab run hot-cold --set 'a=<1>'",
        "beef002",
    );
    std::fs::write(results.join("extra/overview.svg"), SVG).unwrap();
    write_png(&results.join("extra/run one/preview_0001.png"));
    write_manifest(
        &results.join("extra/run one"),
        "smokelab run slab-box",
        "beef003",
    );

    let html = gallery(results);
    let linked = links(&html);
    for f in figures(results) {
        assert!(linked.contains(&f.replace(' ', "%20")), "{f} is not linked");
    }
    assert_links_exist(&html, results);
    // Every command and commit, escaped for HTML, and the registry's title.
    for needle in [
        "smokelab experiment 06-1 --out x",
        "smokelab run hot-cold --set &#39;a=&lt;1&gt;&#39;",
        "smokelab run slab-box",
        "c0ffee1",
        "beef002",
        "beef003",
        "smokelab experiment 06-1</code>",
        registry::find("06-1").unwrap().title,
    ] {
        assert!(html.contains(needle), "the page does not name {needle}");
    }
    // The run folder's figure is credited to its own manifest, not the
    // folder's above it.
    let run = html.split("<h3>extra/run one</h3>").nth(1).unwrap();
    let run_prov = run.split("</p>").next().unwrap();
    assert!(run_prov.contains("beef003"), "{run_prov}");
    // An SVG without a PNG twin is shown itself.
    assert!(html.contains("<img src=\"extra/overview.svg\""));
    // The section is anchored by the experiment's id, and the contents
    // link to it.
    assert!(html.contains("<section id=\"06-1\">"), "no #06-1 section");
    assert!(html.contains("href=\"#06-1\""), "no link to #06-1");
    // The captioned figure first, with its generated caption; the preview,
    // which has no caption, folded away after it, captioned by nothing but
    // its path (no caption repeats the title).
    let section = html.split("<section id=\"06-1\">").nth(1).unwrap();
    let section = section.split("</section>").next().unwrap();
    let (open, folded) = section
        .split_once("<details>")
        .expect("previews folded away");
    assert!(open.contains("Rows: passing; head-on.<br><code>06-1/sequence.png</code>"));
    assert!(!open.contains("preview_0001"), "{open}");
    assert!(
        folded.contains("<figcaption><code>06-1/preview_0001.png</code>"),
        "{folded}"
    );
    assert!(!html.contains(&format!(" — {}", registry::find("06-1").unwrap().title)));
    // Nothing but the page was written.
    let mut written: Vec<_> = std::fs::read_dir(results)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    written.sort();
    assert_eq!(written, ["06-1", "extra", "index.html"]);
}

#[test]
fn a_missing_folder_or_one_without_manifests_is_refused() {
    let sb = Sandbox::new();
    let err = sb.refused(
        &["gallery", "--results", "nope"],
        &["nope", "cannot be read"],
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!sb.join("nope").exists());

    write_png(&sb.join("bare/a/fig.png"));
    sb.refused(
        &["gallery", "--results", "bare"],
        &["holds no manifest.json"],
    );
    assert!(!sb.join("bare/index.html").exists());

    std::fs::write(sb.join("file"), "x").unwrap();
    sb.refused(&["gallery", "--results", "file"], &["is not a folder"]);
}

/// A copy of the committed `results/` with `paper/paper.md` beside it (the
/// captions' source), so the test writes nothing into the checkout.
fn committed_results() -> (tempfile::TempDir, PathBuf) {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let tmp = tempfile::tempdir().unwrap();
    copy_tree(&repo.join("results"), &tmp.path().join("results"));
    copy_tree(&repo.join("paper"), &tmp.path().join("paper"));
    let _ = std::fs::remove_file(tmp.path().join("results/index.html"));
    let results = tmp.path().join("results");
    (tmp, results)
}

#[test]
fn every_committed_figure_is_on_the_page() {
    let (_tmp, results) = committed_results();
    let html = gallery(&results);
    let linked = links(&html);
    let all = figures(&results);
    // 257 PNG/SVG files were committed when this test was written.
    assert!(all.len() > 100, "only {} figures under results/", all.len());
    let missing: Vec<_> = all.iter().filter(|f| !linked.contains(*f)).collect();
    assert!(missing.is_empty(), "not on the page: {missing:?}");
    assert_links_exist(&html, &results);
    // Every registered experiment with a folder has its heading, and the
    // paper's alt text captions the figures the paper shows.
    for e in registry::ALL {
        if results.join(e.folder).is_dir() {
            assert!(
                html.contains(&format!("<h2>{} (", e.id)),
                "no heading for {}",
                e.id
            );
        }
    }
    // A figure's caption is the one its experiment generated from its
    // labels (figures.json), else the paper's alt text.
    let generated: std::collections::BTreeMap<String, String> =
        serde_json::from_str(&std::fs::read_to_string(results.join("06-1/figures.json")).unwrap())
            .unwrap();
    let caption = &generated["sequence.png"];
    assert!(caption.contains("head-on"), "{caption}");
    assert!(
        html.contains(caption.as_str()),
        "no generated caption {caption}"
    );
    assert!(html.contains("06-3 metrics over time"));
}

/// Screenshot the page of the committed results with headless Chromium
/// (Debian's `chromium`) and check the image is not blank. Run with
/// `cargo test --release -p smokelab-app --test gallery_cli -- --ignored`.
#[test]
#[ignore = "needs /usr/bin/chromium"]
fn the_page_renders_in_a_headless_browser() {
    let (tmp, results) = committed_results();
    gallery(&results);
    let shot = std::env::var_os("GALLERY_SCREENSHOT")
        .map_or_else(|| tmp.path().join("gallery.png"), PathBuf::from);
    let profile = tmp.path().join("chromium-profile");
    let page = results.join("index.html").canonicalize().unwrap();
    let o = std::process::Command::new("/usr/bin/chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!("--screenshot={}", shot.display()))
        .arg("--window-size=1200,2000")
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("run /usr/bin/chromium");
    assert!(
        shot.is_file(),
        "no screenshot: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let img = image::open(&shot).unwrap().to_luma8();
    assert_eq!(img.dimensions(), (1200, 2000));
    // Not blank: measured 237 grey levels and 10.1 % of the pixels darker
    // than mid-grey (the renders' black backgrounds); a page whose images
    // did not load is near-white text on #fafafa (the first try, with the
    // images lazily loaded out of view: one level, nothing dark).
    let levels: BTreeSet<u8> = img.pixels().map(|p| p.0[0]).collect();
    let dark = img.pixels().filter(|p| p.0[0] < 128).count() as f64 / img.len() as f64;
    eprintln!("{} grey levels, dark share {dark:.3}", levels.len());
    assert!(levels.len() > 128, "{} grey levels", levels.len());
    assert!(dark > 0.05, "dark share {dark}");
}
