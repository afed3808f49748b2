//! A newcomer's first hour, as the docs print it: every shell command of the
//! README's quick tour, and of the book's *Getting started* first steps,
//! runs in a fresh `git clone` of this repository (one per page), exits 0, prints where it wrote
//! (each file it made or changed lies under a path its output names), and
//! leaves `git status` clean (what the commands write is either under
//! `runs/` or git-ignored).
//!
//! The commands are read from the clone's own `README.md` and
//! `docs/src/guide/getting-started.md`, so the test follows the docs as
//! committed. They run through `sh` with the `smokelab` this test suite
//! built first on `PATH` (as `cargo install` would put it), at a smaller
//! size where the docs leave the size to the user: an experiment id gets
//! `--smoke`, and `smokelab run` gets `--res 26` (the smallest 50³ slab-box
//! set-up whose walls are still two cells thick) in place of the printed
//! resolution, so that the walk takes seconds of CPU per command; the
//! frames, and so the frame numbers a later command names, stay as
//! printed. `cargo run --release` is the bare `smokelab` it runs (at its
//! printed size); `cargo test` and `cargo install` are left out (this is
//! `cargo test`); `<time>` in a path is the newest folder of that name;
//! and the field script's `--out /tmp/hc` goes into the test's own
//! temporary folder.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository root (the workspace, one above the app crate).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// The commands of the ```` ```sh ```` blocks of `text` between the
/// headings `from` and the next heading of the same level, comments
/// stripped.
fn commands(text: &str, from: &str) -> Vec<String> {
    let level = from.split(' ').next().unwrap();
    let mut inside = false;
    let mut code = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if !code && line.starts_with('#') {
            let this_level = line.split(' ').next().unwrap();
            if line == from {
                inside = true;
                continue;
            }
            if inside && this_level.len() <= level.len() {
                break;
            }
        }
        if !inside {
            continue;
        }
        if line.trim_start().starts_with("```") {
            code = !code && line.trim() == "```sh";
            continue;
        }
        if code {
            let command = line.split(" # ").next().unwrap().trim();
            if !command.is_empty() {
                out.push(command.to_string());
            }
        }
    }
    out
}

/// `command` as the walk runs it (the module documentation's rules), or
/// `None` for a command it leaves out.
fn as_walked(command: &str, clone: &Path, tmp: &Path) -> Option<String> {
    if command.starts_with("cargo test") || command.starts_with("cargo install") {
        return None;
    }
    let command = if command == "cargo run --release" {
        "smokelab".to_string()
    } else {
        command.to_string()
    };
    let mut words: Vec<String> = command.split(' ').map(str::to_string).collect();
    // `<time>`: the newest folder of that name (the highest seconds).
    for word in &mut words {
        if let Some((prefix, rest)) = word.split_once("<time>") {
            let (dir, name) = prefix.rsplit_once('/').unwrap();
            let newest = std::fs::read_dir(clone.join(dir))
                .unwrap()
                .map(|e| e.unwrap().file_name().into_string().unwrap())
                .filter(|n| {
                    n.strip_prefix(name)
                        .is_some_and(|t| t.bytes().all(|b| b.is_ascii_digit() || b == b'-'))
                })
                .max_by_key(|n| {
                    n[name.len()..]
                        .split('-')
                        .next()
                        .unwrap()
                        .parse::<u64>()
                        .unwrap_or(0)
                })
                .unwrap_or_else(|| panic!("{command}: no {dir}/{name}<time> folder yet"));
            *word = format!("{dir}/{newest}{rest}");
        }
        if word.as_str() == "/tmp/hc" {
            *word = tmp.join("hc").display().to_string();
        }
    }
    if words.first().map(String::as_str) == Some("smokelab") {
        match words.get(1).map(String::as_str) {
            Some("run") if !words.iter().any(|w| w == "--print-config") => {
                if let Some(i) = words.iter().position(|w| w == "--res") {
                    words.drain(i..i + 2);
                }
                let end = words.iter().position(|w| w == ">").unwrap_or(words.len());
                words.splice(end..end, ["--res".to_string(), "26".to_string()]);
            }
            Some("experiment") if words.len() == 3 && !words[2].starts_with('-') => {
                words.push("--smoke".into());
            }
            _ => {}
        }
    }
    Some(words.join(" "))
}

/// Every file under `dir` (`.git` aside) with its size and modification
/// time, by path relative to `dir`.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, (u64, std::time::SystemTime)> {
    fn walk(root: &Path, rel: &Path, out: &mut BTreeMap<PathBuf, (u64, std::time::SystemTime)>) {
        for entry in std::fs::read_dir(root.join(rel)).unwrap() {
            let entry = entry.unwrap();
            let path = rel.join(entry.file_name());
            let meta = entry.metadata().unwrap();
            if meta.is_dir() {
                if path != Path::new(".git") {
                    walk(root, &path, out);
                }
            } else {
                out.insert(path, (meta.len(), meta.modified().unwrap()));
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, Path::new(""), &mut out);
    out
}

/// Whether `text` names `path` as a whole word: not inside a longer name
/// (`render` is not named by `rendered`).
fn names(text: &str, path: &str) -> bool {
    let word = |c: char| c.is_alphanumeric() || c == '-' || c == '_';
    text.match_indices(path)
        .any(|(at, _)| !text[..at].ends_with(word) && !text[at + path.len()..].starts_with(word))
}

/// The shell's redirect target of `command` (`> my.toml`), written by the
/// shell rather than by smokelab.
fn redirect(command: &str) -> Option<&str> {
    command.split_once('>').map(|(_, t)| t.trim())
}

/// Walk the commands of `doc`'s section `heading` in a fresh clone; the
/// number of commands walked.
fn walk(doc: &str, heading: &str) -> usize {
    let tmp = tempfile::tempdir().unwrap();
    let clone = tmp.path().join("smokelab");
    let cloned = Command::new("git")
        .args(["clone", "--quiet"])
        .arg(root())
        .arg(&clone)
        .output()
        .unwrap();
    assert!(
        cloned.status.success(),
        "git clone: {}",
        String::from_utf8_lossy(&cloned.stderr)
    );
    let bin = tmp.path().join("bin");
    std::fs::create_dir(&bin).unwrap();
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_smokelab"), bin.join("smokelab")).unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let printed = commands(&std::fs::read_to_string(clone.join(doc)).unwrap(), heading);
    assert!(
        printed.iter().any(|c| c.starts_with("smokelab render")),
        "{doc}: {printed:?}"
    );
    let mut walked = 0;
    for command in &printed {
        let Some(run) = as_walked(command, &clone, tmp.path()) else {
            continue;
        };
        let before = snapshot(&clone);
        let out = Command::new("sh")
            .args(["-c", &run])
            .current_dir(&clone)
            .env("PATH", &path)
            .output()
            .unwrap();
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            out.status.success(),
            "{doc}: `{command}` (run as `{run}`) failed:\n{text}"
        );
        let after = snapshot(&clone);
        for (file, stamp) in &after {
            if before.get(file) == Some(stamp) || redirect(&run) == file.to_str() {
                continue;
            }
            let named = file
                .ancestors()
                .filter(|a| !a.as_os_str().is_empty() && *a != Path::new("runs"))
                .any(|a| names(&text, a.to_str().unwrap()));
            assert!(
                named,
                "{doc}: `{command}` (run as `{run}`) wrote {} but did not say where:\n{text}",
                file.display()
            );
        }
        walked += 1;
    }
    let status = Command::new("git")
        .args(["status", "--porcelain"])
        .current_dir(&clone)
        .output()
        .unwrap();
    assert!(status.status.success());
    assert!(
        status.stdout.is_empty(),
        "{doc}: its commands leave files git does not ignore:\n{}",
        String::from_utf8_lossy(&status.stdout)
    );
    walked
}

/// The README's quick tour, from a fresh clone.
#[test]
fn the_readme_tour_runs_as_printed_in_a_fresh_clone() {
    let walked = walk("README.md", "## A quick tour");
    assert!(walked >= 10, "only {walked} commands walked");
}

/// The book's first steps, from a fresh clone of their own (a reader of
/// that page has not followed the README's tour).
#[test]
fn getting_started_runs_as_printed_in_a_fresh_clone() {
    let walked = walk("docs/src/guide/getting-started.md", "## First steps");
    assert!(walked >= 6, "only {walked} commands walked");
}

#[test]
fn the_walk_reads_and_rewrites_commands_as_documented() {
    let text = "# A\n## Tour\n```sh\nsmokelab run hot-cold --res 64 --frames 100   # comment\n```\n```python\nx = 1\n```\n### Sub\n```sh\nsmokelab experiment 06-5\n```\n## Next\n```sh\nsmokelab gallery\n```\n";
    assert_eq!(
        commands(text, "## Tour"),
        [
            "smokelab run hot-cold --res 64 --frames 100",
            "smokelab experiment 06-5"
        ]
    );
    let tmp = tempfile::tempdir().unwrap();
    let clone = tmp.path();
    std::fs::create_dir_all(clone.join("runs/hot-cold-20")).unwrap();
    std::fs::create_dir_all(clone.join("runs/hot-cold-100")).unwrap();
    std::fs::create_dir_all(clone.join("runs/slab-box-300")).unwrap();
    let walk = |c: &str| as_walked(c, clone, Path::new("/t"));
    assert_eq!(
        walk("smokelab run hot-cold --res 64 --frames 100").unwrap(),
        "smokelab run hot-cold --frames 100 --res 26"
    );
    assert_eq!(
        walk("smokelab run hot-cold --print-config > my.toml").unwrap(),
        "smokelab run hot-cold --print-config > my.toml"
    );
    assert_eq!(
        walk("smokelab experiment 06-5").unwrap(),
        "smokelab experiment 06-5 --smoke"
    );
    assert_eq!(
        walk("smokelab experiment --list").unwrap(),
        "smokelab experiment --list"
    );
    assert_eq!(
        walk("smokelab render runs/hot-cold-<time>/ --out render/").unwrap(),
        "smokelab render runs/hot-cold-100/ --out render/"
    );
    assert_eq!(walk("cargo run --release").unwrap(), "smokelab");
    assert_eq!(walk("cargo test --release"), None);
    assert!(names("wrote render/render_0150.exr", "render"));
    assert!(!names("rendered 512x512", "render"));
    assert!(names("wrote runs/hot-cold-100", "runs/hot-cold-100"));
}
