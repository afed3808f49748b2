//! The application lives in rooms (the folders under `experiments/`), and
//! imports travel one way between them. This test reads every source file
//! of the app, resolves each `crate::…`, `super::…` and child-module path
//! to the file it names, and checks, from the bottom room up:
//!
//! - `figures` uses no other room;
//! - the run driver (`run`) uses only `figures`;
//! - field scripts (`script`) and the numbered experiments (`experiment`)
//!   use only `run` and `figures` — an experiment never the command line
//!   or publishing;
//! - publishing (`publish`) uses `experiment` (the registry), `run` and
//!   `figures`; the command line (`cli`) may use every room;
//! - no two files import each other, directly or round a loop (within a
//!   room too), and no two rooms do;
//! - nothing outside `experiment/` names a particular experiment, and no
//!   experiment names another: they share through `experiment/shared/`.
//!
//! Comment lines are skipped (a doc link is not a dependency).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Each room and the rooms it may use, bottom up (the order `lib.rs`
/// declares them).
const ROOMS: &[(&str, &[&str])] = &[
    ("figures", &[]),
    ("run", &["figures"]),
    ("script", &["run", "figures"]),
    ("experiment", &["run", "figures"]),
    ("publish", &["experiment", "run", "figures"]),
    (
        "cli",
        &["publish", "experiment", "script", "run", "figures"],
    ),
];

/// The app's source root (`experiments/`).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf()
}

/// The module path of a source file relative to the root:
/// `experiment/shared/growth.rs` → `experiment::shared::growth`,
/// `run/mod.rs` → `run`.
fn module_of(rel: &Path) -> String {
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().expect("a file name");
    let stem = last.trim_end_matches(".rs");
    if stem != "mod" {
        parts.push(stem.to_string());
    }
    parts.join("::")
}

/// Every `.rs` file of the rooms, by module path.
fn sources() -> BTreeMap<String, String> {
    fn walk(dir: &Path, root: &Path, out: &mut BTreeMap<String, String>) {
        for e in std::fs::read_dir(dir).expect("read a source folder") {
            let p = e.expect("entry").path();
            if p.is_dir() {
                walk(&p, root, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let rel = p.strip_prefix(root).expect("under the root");
                let text = std::fs::read_to_string(&p).expect("read a source");
                out.insert(module_of(rel), text);
            }
        }
    }
    let root = root();
    let mut out = BTreeMap::new();
    for (room, _) in ROOMS {
        let dir = root.join(room);
        assert!(dir.is_dir(), "room {room} is a folder under experiments/");
        walk(&dir, &root, &mut out);
    }
    out
}

/// `text` without its comment lines.
fn without_comments(text: &str) -> String {
    text.lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// `code` without its inline test modules (`#[cfg(test)] mod tests { … }`):
/// their `super::` is the file's own module, and tests are no part of the
/// map.
fn without_inline_tests(code: &str) -> String {
    let mut out = String::new();
    let mut rest = code;
    while let Some(at) = rest.find("#[cfg(test)]") {
        let after = &rest[at + "#[cfg(test)]".len()..];
        let body = after.trim_start();
        let Some(open) = body
            .find('{')
            .filter(|&o| body.starts_with("mod ") && !body[..o].contains(';'))
        else {
            out.push_str(&rest[..at + "#[cfg(test)]".len()]);
            rest = after;
            continue;
        };
        out.push_str(&rest[..at]);
        let mut depth = 0usize;
        let mut end = body.len();
        for (i, c) in body[open..].char_indices() {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        end = open + i + 1;
                        break;
                    }
                }
                _ => {}
            }
        }
        rest = &body[end..];
    }
    out.push_str(rest);
    out
}

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// The paths a `use`-like path starting at `s` spells: `a::b::c` is one,
/// `a::{b, c::{d, self}}` is `a::b`, `a::c::d`, `a::c`. Returns the paths
/// (segments) and how many bytes were read.
fn read_path(s: &str) -> (Vec<Vec<String>>, usize) {
    let mut i = 0;
    let mut prefix = Vec::new();
    loop {
        let word: String = s[i..].chars().take_while(|&c| is_ident(c)).collect();
        if word.is_empty() {
            if s[i..].starts_with('{') {
                // A group: each item a path of its own under `prefix`.
                i += 1;
                let mut out = Vec::new();
                loop {
                    let rest = &s[i..];
                    let skip = rest.len() - rest.trim_start().len();
                    i += skip;
                    if s[i..].starts_with('}') {
                        return (out, i + 1);
                    }
                    let (items, used) = read_path(&s[i..]);
                    for item in items {
                        let mut p = prefix.clone();
                        p.extend(item.into_iter().filter(|w| w != "self"));
                        out.push(p);
                    }
                    i += used.max(1);
                    let rest = &s[i..];
                    i += rest.len() - rest.trim_start().len();
                    if s[i..].starts_with(',') {
                        i += 1;
                    }
                }
            }
            return (vec![prefix], i);
        }
        i += word.len();
        prefix.push(word);
        if s[i..].starts_with("::") {
            i += 2;
        } else {
            // `a::b as c`, `a::b;`, `a::b(…)`: the path ends here.
            let rest = &s[i..];
            if let Some(r) = rest.trim_start().strip_prefix("as ") {
                let alias: String = r
                    .trim_start()
                    .chars()
                    .take_while(|&c| is_ident(c))
                    .collect();
                i = s.len() - r.trim_start().len() + alias.len();
            }
            return (vec![prefix], i);
        }
    }
}

/// The modules `module`'s code names: every `crate::`, `super::` and
/// `self::` path, and paths through the child modules it declares.
fn named_modules(module: &str, code: &str, known: &BTreeSet<String>) -> BTreeSet<String> {
    let own: Vec<&str> = if module.is_empty() {
        vec![]
    } else {
        module.split("::").collect()
    };
    let children: BTreeSet<String> = code
        .lines()
        .filter_map(|l| {
            let l = l.trim_start();
            let l = l
                .strip_prefix("pub ")
                .or(l.strip_prefix("pub(crate) "))
                .unwrap_or(l);
            let l = l.strip_prefix("pub(super) ").unwrap_or(l);
            l.strip_prefix("mod ")?
                .strip_suffix(';')
                .map(str::to_string)
        })
        .collect();
    let mut found = BTreeSet::new();
    let bytes = code.as_bytes();
    for (at, _) in code.char_indices() {
        if at > 0 && (is_ident(bytes[at - 1] as char) || bytes[at - 1] == b':') {
            continue;
        }
        let rest = &code[at..];
        let word: String = rest.chars().take_while(|&c| is_ident(c)).collect();
        if word.is_empty() || !rest[word.len()..].starts_with("::") {
            continue;
        }
        let (paths, _) = read_path(rest);
        for path in paths {
            let mut full: Vec<String> = match path[0].as_str() {
                "crate" => vec![],
                "self" => own.iter().map(|s| s.to_string()).collect(),
                "super" => own[..own.len().saturating_sub(1)]
                    .iter()
                    .map(|s| s.to_string())
                    .collect(),
                w if children.contains(w) => {
                    let mut p: Vec<String> = own.iter().map(|s| s.to_string()).collect();
                    p.push(w.to_string());
                    p.extend(path[1..].iter().cloned());
                    resolve(&p, known, &mut found);
                    continue;
                }
                _ => continue,
            };
            let mut rest = &path[1..];
            while rest.first().is_some_and(|w| w == "super") {
                full.pop();
                rest = &rest[1..];
            }
            full.extend(rest.iter().cloned());
            resolve(&full, known, &mut found);
        }
    }
    found.remove(module);
    found
}

/// The longest prefix of `path` that is a module of the app, if any.
fn resolve(path: &[String], known: &BTreeSet<String>, found: &mut BTreeSet<String>) {
    for n in (1..=path.len()).rev() {
        let m = path[..n].join("::");
        if known.contains(&m) {
            found.insert(m);
            return;
        }
    }
}

fn room_of(module: &str) -> &str {
    module.split("::").next().unwrap_or_default()
}

/// The import graph: each module and the modules it names.
fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let sources = sources();
    let known: BTreeSet<String> = sources.keys().cloned().collect();
    sources
        .iter()
        .map(|(m, text)| {
            let code = without_inline_tests(&without_comments(text));
            (m.clone(), named_modules(m, &code, &known))
        })
        .collect()
}

/// The loops of `graph`: its strongly connected components of more than
/// one node (Tarjan's algorithm), each sorted.
fn cycles(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct State<'a> {
        graph: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a str) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        s.on_stack.insert(v);
        let edges = s.graph.get(v).into_iter().flatten();
        for w in edges {
            let w = w.as_str();
            if !s.graph.contains_key(w) {
                continue;
            }
            if !s.index.contains_key(w) {
                visit(s, w);
                let lw = s.low[w];
                let lv = s.low.get_mut(v).expect("visited");
                *lv = (*lv).min(lw);
            } else if s.on_stack.contains(w) {
                let iw = s.index[w];
                let lv = s.low.get_mut(v).expect("visited");
                *lv = (*lv).min(iw);
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = vec![];
            loop {
                let w = s.stack.pop().expect("v is on the stack");
                s.on_stack.remove(w);
                component.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if component.len() > 1 {
                component.sort();
                s.out.push(component);
            }
        }
    }
    let mut s = State {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: vec![],
        on_stack: BTreeSet::new(),
        out: vec![],
    };
    for v in graph.keys() {
        if !s.index.contains_key(v.as_str()) {
            visit(&mut s, v);
        }
    }
    s.out.sort();
    s.out
}

/// The rooms' own graph: room → the rooms its files use.
fn room_graph(graph: &BTreeMap<String, BTreeSet<String>>) -> BTreeMap<String, BTreeSet<String>> {
    let mut rooms: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (m, used) in graph {
        let entry = rooms.entry(room_of(m).to_string()).or_default();
        for u in used {
            if room_of(u) != room_of(m) {
                entry.insert(room_of(u).to_string());
            }
        }
    }
    rooms
}

/// Whether the file stem names a numbered experiment: `e06_1_…`, `ep_1_…`,
/// `ev_1_…`, `s1_…`.
fn is_experiment(stem: &str) -> bool {
    let mut parts = stem.splitn(3, '_');
    let (Some(a), Some(b)) = (parts.next(), parts.next()) else {
        return false;
    };
    let numbered = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_digit());
    (a.starts_with('e')
        && a.len() > 1
        && a[1..].chars().all(|c| c.is_ascii_alphanumeric())
        && numbered(b))
        || (a.starts_with('s') && numbered(&a[1..]))
}

#[test]
fn lib_declares_the_rooms_bottom_up() {
    let lib = std::fs::read_to_string(root().join("lib.rs")).expect("read lib.rs");
    let declared: Vec<&str> = lib
        .lines()
        .filter_map(|l| l.strip_prefix("pub mod "))
        .map(|m| m.trim_end_matches(';'))
        .collect();
    let rooms: Vec<&str> = ROOMS.iter().map(|(r, _)| *r).collect();
    assert_eq!(
        declared, rooms,
        "lib.rs declares the rooms of this test, in its order"
    );
    // Every room may use only rooms below it: the allowed arrows have no loop.
    for (n, (room, uses)) in ROOMS.iter().enumerate() {
        for u in *uses {
            let below = ROOMS[..n].iter().any(|(r, _)| r == u);
            assert!(below, "{room} may use {u}, which is not below it");
        }
    }
}

#[test]
fn every_room_uses_only_the_rooms_it_may() {
    let graph = graph();
    assert!(
        graph.len() > 50 && graph.contains_key("experiment::registry"),
        "the scan found the app's files: {:?}",
        graph.keys().collect::<Vec<_>>()
    );
    let allowed: BTreeMap<&str, &[&str]> = ROOMS.iter().copied().collect();
    let mut wrong = vec![];
    for (m, used) in &graph {
        for u in used {
            let (from, to) = (room_of(m), room_of(u));
            if from != to && !allowed[from].contains(&to) {
                wrong.push(format!("{m} ({from}) uses {u} ({to})"));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "imports against the rooms' order:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn no_file_and_no_room_imports_round_a_loop() {
    let graph = graph();
    // The scan sees the arrows it must: the registry lists the experiments,
    // the loop draws with the figures.
    assert!(graph["experiment::registry"].contains("experiment::e06_1_hot_cold_gridded"));
    assert!(graph["run"].iter().any(|m| room_of(m) == "figures"));
    let files = cycles(&graph);
    assert!(files.is_empty(), "files that import each other: {files:?}");
    let rooms = cycles(&room_graph(&graph));
    assert!(rooms.is_empty(), "rooms that import each other: {rooms:?}");
}

#[test]
fn the_loop_finder_finds_loops_between_files_and_between_rooms() {
    let g = |edges: &[(&str, &str)]| {
        let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (a, b) in edges {
            g.entry(a.to_string()).or_default().insert(b.to_string());
            g.entry(b.to_string()).or_default();
        }
        g
    };
    // Two files round a loop, a third outside it.
    let files = g(&[
        ("run::a", "run::b"),
        ("run::b", "run::a"),
        ("run::a", "figures::c"),
    ]);
    assert_eq!(
        cycles(&files),
        vec![vec!["run::a".to_string(), "run::b".to_string()]]
    );
    // No file loop, but the rooms loop: run::a → cli::x, cli::y → run::b.
    let rooms = g(&[("run::a", "cli::x"), ("cli::y", "run::b")]);
    assert!(cycles(&rooms).is_empty());
    assert_eq!(
        cycles(&room_graph(&rooms)),
        vec![vec!["cli".to_string(), "run".to_string()]]
    );
}

#[test]
fn the_path_reader_resolves_groups_super_and_children() {
    let known: BTreeSet<String> = [
        "run",
        "run::frames",
        "figures::plot",
        "experiment::kit",
        "experiment::registry",
        "script::types",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let code = "use crate::experiment::{kit, registry::{self, find}};\nlet p = crate::figures::plot::Plot::new();\nuse super::types::Region;\nmod frames;\nframes::x();";
    let found = named_modules("script::output", code, &known);
    assert_eq!(
        found,
        [
            "experiment::kit",
            "experiment::registry",
            "figures::plot",
            "script::types"
        ]
        .iter()
        .map(|s| s.to_string())
        .collect()
    );
    let found = named_modules(
        "run",
        "mod frames;\nlet s = frames::simulation_scene(sim);",
        &known,
    );
    assert_eq!(found, ["run::frames".to_string()].into_iter().collect());
    // An inline test module's `super::` is the file itself: no arrow.
    let code = "fn a() {}\n#[cfg(test)]\nmod tests {\n    use super::*;\n    fn b() { if x { y } }\n}\nfn c() {}";
    assert_eq!(without_inline_tests(code), "fn a() {}\n\nfn c() {}");
}

#[test]
fn only_the_registry_names_an_experiment_and_no_experiment_another() {
    let graph = graph();
    let experiments: Vec<&String> = graph
        .keys()
        .filter(|m| m.strip_prefix("experiment::").is_some_and(is_experiment))
        .collect();
    assert!(
        experiments.len() >= 30 && experiments.iter().any(|m| m.ends_with("s1_symmetry")),
        "the scan found the experiments: {experiments:?}"
    );
    let mut found = vec![];
    for (m, used) in &graph {
        for e in experiments.iter().filter(|e| used.contains(**e)) {
            if m != "experiment::registry" && m != "experiment" {
                found.push(format!("{m} names {e}"));
            }
        }
    }
    assert!(
        found.is_empty(),
        "experiments named outside the registry:\n{}",
        found.join("\n")
    );
}
