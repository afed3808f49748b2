//! `src/lib.rs` declares the library's modules in dependency order, each
//! using only those above it. This test keeps that claim true: it reads
//! every module's source and fails on a path `crate::m` (or `crate::{m, …}`)
//! to a module declared below it. Comment lines are skipped (a doc link is
//! not a dependency).

use std::path::{Path, PathBuf};

/// The top-level modules in the order `lib.rs` declares them.
fn declared_modules(lib: &str) -> Vec<String> {
    lib.lines()
        .filter_map(|l| l.strip_prefix("pub mod "))
        .map(|m| m.trim_end_matches(';').to_string())
        .collect()
}

/// The top-level module names after every `crate::` in `code` (the first
/// segment of each item of a `crate::{…}` group, nested groups included).
fn crate_paths(code: &str) -> Vec<String> {
    let mut out = vec![];
    let mut rest = code;
    while let Some(at) = rest.find("crate::") {
        rest = &rest[at + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            // Items at depth 1 of the balanced group.
            let (mut depth, mut item_start) = (1usize, true);
            for (i, ch) in group.char_indices() {
                match ch {
                    '{' => depth += 1,
                    '}' => {
                        depth -= 1;
                        if depth == 0 {
                            rest = &group[i..];
                            break;
                        }
                    }
                    ',' if depth == 1 => item_start = true,
                    c if item_start && depth == 1 && (c.is_alphanumeric() || c == '_') => {
                        let word: String = group[i..]
                            .chars()
                            .take_while(|c| c.is_alphanumeric() || *c == '_')
                            .collect();
                        out.push(word);
                        item_start = false;
                    }
                    _ => {}
                }
            }
        } else {
            let word: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            out.push(word);
        }
    }
    out
}

/// `code` without its comment lines.
fn without_comments(text: &str) -> String {
    text.lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn every_module_uses_only_modules_declared_above_it() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let modules = declared_modules(&std::fs::read_to_string(src.join("lib.rs")).unwrap());
    assert!(modules.len() >= 10, "lib.rs declares {modules:?}");
    let mut violations = vec![];
    for (rank, module) in modules.iter().enumerate() {
        let mut files = vec![];
        let file = src.join(format!("{module}.rs"));
        if file.is_file() {
            files.push(file);
        }
        if src.join(module).is_dir() {
            rust_files(&src.join(module), &mut files);
        }
        assert!(!files.is_empty(), "no source for module {module}");
        for f in files {
            let code = without_comments(&std::fs::read_to_string(&f).unwrap());
            for used in crate_paths(&code) {
                if let Some(r) = modules.iter().position(|m| *m == used) {
                    if r > rank {
                        violations.push(format!(
                            "{}: {module} uses {used}, declared below it",
                            f.strip_prefix(&src).unwrap().display()
                        ));
                    }
                }
            }
        }
    }
    violations.sort();
    violations.dedup();
    assert!(violations.is_empty(), "{}", violations.join("\n"));
}

#[test]
fn the_path_reader_finds_groups_and_plain_paths() {
    let code = "use crate::grid::{FaceGrid, Wrap};\nuse crate::{domain::Domain, metrics::{rms_max, RmsMax}, simd};\nlet x = crate::density::wrap_grid(p);";
    assert_eq!(
        crate_paths(code),
        ["grid", "domain", "metrics", "simd", "density"]
    );
    assert_eq!(
        without_comments("// crate::render\nlet a = 1;"),
        "let a = 1;"
    );
}
