//! `smokelab script FILE`: the notes' FELT scripts, run almost as printed.
//!
//! A script **builds** a field graph — the library's `Arc`'d
//! [`smokelab::field::ScalarField`] / [`smokelab::field::VectorField`]
//! nodes — and calls native verbs on grids (`advect` of a cache,
//! `fftdivfree`, `cachewrite`); every evaluation is native and batched, the
//! interpreter never runs per point. Types and operators: [`types`]; the
//! notes' functions: [`functions`]; SELMA's map cache: [`map`]; files:
//! [`output`].
//!
//! **Why Rhai.** It is pure Rust (no C library, nothing to install beside
//! the crate), sandboxed by default (no file, network or process access
//! unless registered; here only [`output`]'s writers, confined to `--out`),
//! it takes custom types with overloaded operators (`hot - cold`, `dt*gravity`,
//! `B*M*B`), and its errors carry a line and column, which every message
//! here reports as `FILE:LINE:COL`. Its syntax differs from FELT's in small
//! ways each script's header lists: `let x = …` instead of a typed
//! declaration, `scalarcache(region, "hot")` instead of
//! `scalarcache hotCache(region)`, `^` binding looser than `*`.
//!
//! **Parameters.** `let res = param("res", 32);` reads `--set res=…` (parsed
//! as the default's type) or keeps the default; a `--set` of a name no
//! `param("…")` in the file mentions is refused before the script runs.
//!
//! **Errors** (exit 2): a syntax error, an unknown function, or a call with
//! the wrong types (Rhai names them: `Function not found: mask (vector)`)
//! are reported as `FILE:LINE:COL: message`, on one line; so is a limit
//! reached ([`limits`]: operations, call depth, string, array and map sizes)
//! and an `import` from anywhere but the script's folder and the shipped
//! scripts' ([`modules`]). A field that became non-finite when a frame,
//! metrics row or array is written stops the script with exit 1, naming
//! the step and the field ([`output`]).
//!
//! **The folder.** `--out`, or a new `runs/script-<stem>-<seconds>` for
//! each run (as `smokelab run` makes one), under the rule every command
//! follows ([`crate::run::output_dir`]). The script is compiled before
//! the folder is made: a syntax error leaves nothing behind. A script that
//! fails before writing anything leaves no manifest (and no folder it made);
//! one that fails later leaves what it wrote and a manifest saying
//! `failed`, and the next script run into that folder replaces them
//! without `--overwrite`. The last line on stdout names the folder.

pub mod functions;
pub mod limits;
pub mod map;
pub mod modules;
pub mod output;
pub mod types;

#[cfg(test)]
mod tests;

use std::cell::{Cell, RefCell};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::time::Instant;

use anyhow::{anyhow, Result};
use clap::Args;
use rhai::{Dynamic, Engine, EvalAltResult, Position, Scope, FLOAT, INT};
use serde::Serialize;
use smokelab::error::InputError;
use smokelab::io::{self, manifest::Manifest};
use smokelab::pressure::PressurePrecision;

use indicatif::{ProgressBar, ProgressStyle};
use output::Recorder;

use crate::run::output_dir;

/// `smokelab script`.
#[derive(Debug, Args)]
pub struct ScriptArgs {
    /// The script (`experiments/scripts/*.rhai`).
    pub file: PathBuf,
    /// Override a `param("name", default)` of the script, e.g. `--set res=32` (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// Output folder (default: a new `runs/script-<file stem>-<seconds>` each run); the script writes only inside it.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace an earlier run's outputs in the folder (frames, arrays,
    /// metrics, manifest); without it such a folder is refused, unless
    /// that run failed.
    #[arg(long)]
    pub overwrite: bool,
    /// Transforms of every `domain`'s pressure solve (`fftdivfree`, `diffuse`): f32 (default) or f64, as `smokelab run --pressure-precision`.
    #[arg(long, value_enum, default_value_t)]
    pub pressure_precision: PressurePrecision,
    /// The most interpreter operations the script may run (statements,
    /// expressions, calls; a native verb such as `advect` counts once
    /// whatever its grid): stops a script that never ends.
    #[arg(long, value_name = "N", default_value_t = limits::DEFAULT_MAX_OPERATIONS,
          value_parser = clap::value_parser!(u64).range(1..))]
    pub max_operations: u64,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// What the manifest records as the run's configuration.
#[derive(Serialize)]
struct ScriptConfig {
    script: String,
    /// The transforms of every `domain`'s pressure solve.
    pressure_precision: PressurePrecision,
    /// Every `param` the script read, as it resolved.
    params: BTreeMap<String, String>,
    /// The operation limit (`--max-operations`).
    max_operations: u64,
}

/// The `--set` values and the parameters read so far.
#[derive(Default)]
struct Params {
    set: BTreeMap<String, String>,
    read: BTreeMap<String, String>,
}

/// The names of `param("…")` calls in the source text.
fn declared_params(source: &str) -> Vec<String> {
    source
        .match_indices("param(")
        .filter_map(|(i, m)| {
            let rest = source[i + m.len()..].trim_start().strip_prefix('"')?;
            rest.find('"').map(|end| rest[..end].to_string())
        })
        .collect()
}

/// `--set name=value` pairs, each naming a declared parameter.
fn parse_sets(
    sets: &[String],
    declared: &[String],
    file: &str,
) -> Result<BTreeMap<String, String>, InputError> {
    let mut out = BTreeMap::new();
    for s in sets {
        let (name, value) = s
            .split_once('=')
            .ok_or_else(|| InputError::new(format!("--set {s}: expected NAME=VALUE")))?;
        let name = name.trim();
        if !declared.iter().any(|d| d == name) {
            return Err(InputError::new(format!(
                "--set {name}: {file} has no param(\"{name}\", …); its parameters are: {}",
                if declared.is_empty() {
                    "none".to_string()
                } else {
                    declared.join(", ")
                }
            )));
        }
        out.insert(name.to_string(), value.trim().to_string());
    }
    Ok(out)
}

/// `value` parsed as the type of `default`.
fn parse_as(name: &str, value: &str, default: &Dynamic) -> Result<Dynamic, Box<EvalAltResult>> {
    let bad = |t: &str| -> Box<EvalAltResult> {
        format!("--set {name}={value}: expected {t}, the type of the default").into()
    };
    if default.is::<INT>() {
        value
            .parse::<INT>()
            .map(Dynamic::from)
            .map_err(|_| bad("an integer"))
    } else if default.is::<FLOAT>() {
        value
            .parse::<FLOAT>()
            .map(Dynamic::from)
            .map_err(|_| bad("a number"))
    } else if default.is::<bool>() {
        value
            .parse::<bool>()
            .map(Dynamic::from)
            .map_err(|_| bad("true or false"))
    } else if default.is_string() {
        Ok(Dynamic::from(value.to_string()))
    } else {
        Err(format!(
            "param {name}: a default of type {} cannot be set",
            default.type_name()
        )
        .into())
    }
}

/// `FILE:LINE:COL: message`, on one line (Rhai puts the function or
/// module an error came through on lines of their own).
fn located(file: &str, pos: Position, message: impl std::fmt::Display) -> InputError {
    let message = message.to_string().replace('\n', "; ");
    // A native function's refusal reads as itself, not as Rhai's
    // "Runtime error: …".
    let message = message.strip_prefix("Runtime error: ").unwrap_or(&message);
    match (pos.line(), pos.position()) {
        (Some(l), Some(c)) => InputError::new(format!("{file}:{l}:{c}: {message}")),
        (Some(l), None) => InputError::new(format!("{file}:{l}: {message}")),
        _ => InputError::new(format!("{file}: {message}")),
    }
}

/// The engine with every type, function and writer registered, its
/// limits set ([`limits::apply`], the operations counted into `used`) and
/// `import` confined to the script's folders ([`modules::Modules`]). A
/// `param("frames", …)` sets the progress bar's length.
fn engine(
    args: &ScriptArgs,
    recorder: &Rc<RefCell<Recorder>>,
    params: &Rc<RefCell<Params>>,
    used: &Rc<Cell<u64>>,
) -> Engine {
    let mut engine = Engine::new();
    limits::apply(&mut engine, args.max_operations, used);
    engine.set_module_resolver(modules::Modules::for_script(&args.file));
    types::register(&mut engine);
    functions::register(&mut engine, args.pressure_precision);
    map::register(&mut engine);
    output::register(&mut engine, recorder);
    let (p, r) = (params.clone(), recorder.clone());
    engine.register_fn("param", move |name: &str, default: Dynamic| {
        let mut p = p.borrow_mut();
        let value = match p.set.get(name) {
            Some(v) => parse_as(name, v, &default)?,
            None => default,
        };
        if let (Ok(frames), "frames") = (value.as_int(), name) {
            let progress = &r.borrow().progress;
            progress.set_style(progress_style("{wide_bar} step {pos}/{len}"));
            progress.set_length(frames.max(0) as u64);
        }
        p.read.insert(name.to_string(), value.to_string());
        Ok::<_, Box<EvalAltResult>>(value)
    });
    engine
}

/// Whether `out` holds the manifest of a script run that failed: its
/// outputs are replaced without `--overwrite`.
fn failed_script(out: &Path) -> bool {
    let path = out.join("manifest.json");
    std::fs::symlink_metadata(&path).is_ok()
        && io::input::read_text(&path, "manifest")
            .ok()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
            .is_some_and(|m| m["config"].get("script").is_some() && m["status"] == "failed")
}

/// The default folder: `runs/script-<file stem>-<seconds>`, made fresh
/// ([`output_dir::create_fresh`]: a suffix when another run took it).
fn default_folder(file: &Path) -> Result<PathBuf> {
    let stem = file
        .file_stem()
        .map_or("script".into(), |s| s.to_string_lossy());
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    output_dir::create_fresh(&Path::new("runs").join(format!("script-{stem}-{secs}")))
}

/// The progress line: elapsed time, `steps` (the step recorded; a bar of
/// the script's `frames` once it reads that parameter) and the last frame
/// saved.
fn progress_style(steps: &str) -> ProgressStyle {
    ProgressStyle::with_template(&format!("{{elapsed_precise}} {steps} {{msg}}"))
        .expect("a valid template")
}

/// The progress line ([`progress_style`]), hidden with `--quiet` and when
/// stderr is not a terminal.
fn progress_bar(quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    ProgressBar::no_length().with_style(progress_style("step {pos}"))
}

/// Run a script: read and compile it, check the `--set` names, make the
/// folder, evaluate, write the manifest and say where.
pub fn run(args: &ScriptArgs) -> Result<()> {
    let file = args.file.display().to_string();
    let source = limits::read_script(&args.file, "script")?;
    let params = Rc::new(RefCell::new(Params {
        set: parse_sets(&args.set, &declared_params(&source), &file)?,
        read: BTreeMap::new(),
    }));
    let recorder = Rc::new(RefCell::new(Recorder::default()));
    let used = Rc::new(Cell::new(0));
    let engine = engine(args, &recorder, &params, &used);
    let ast = engine
        .compile(&source)
        .map_err(|e| located(&file, e.1, &e.0))?;
    let (out, created, overwrite) = match &args.out {
        Some(out) => {
            let replaces_failed = !args.overwrite && failed_script(out);
            output_dir::check(out, &output_dir::SCRIPT, args.overwrite || replaces_failed)?;
            if replaces_failed {
                eprintln!(
                    "replacing the outputs of the failed script run in {}",
                    out.display()
                );
            }
            let created = std::fs::symlink_metadata(out).is_err();
            (out.clone(), created, args.overwrite || replaces_failed)
        }
        None => (default_folder(&args.file)?, true, false),
    };
    let folder = output_dir::open(&out, &output_dir::SCRIPT, overwrite)?;
    let progress = progress_bar(args.quiet);
    recorder.borrow_mut().open(out.clone(), progress.clone());
    let start = Instant::now();
    let result = engine.run_ast_with_scope(&mut Scope::new(), &ast);
    progress.finish_and_clear();
    let config = ScriptConfig {
        script: file.clone(),
        pressure_precision: args.pressure_precision,
        params: params.borrow().read.clone(),
        max_operations: args.max_operations,
    };
    let wall = start.elapsed().as_secs_f64();
    let manifest = out.join("manifest.json");
    if let Err(mut e) = result {
        let pos = e.take_position();
        // A field that became non-finite is the numerics' failure (exit 1),
        // anything else the script's (exit 2).
        let non_finite = recorder.borrow_mut().non_finite.take();
        let err = match non_finite {
            Some(why) => anyhow!("{}", located(&file, pos, why)),
            None => match limits::describe(&e, args.max_operations) {
                Some(limit) => located(&file, pos, limit).into(),
                None => located(&file, pos, &e).into(),
            },
        };
        if recorder.borrow().wrote_nothing() {
            drop(folder);
            if created {
                output_dir::remove_if_unwritten(&out);
            }
            return Err(err);
        }
        io::write_json(
            &manifest,
            &Manifest::failed(&config, 0, wall, err.to_string()),
        )?;
        // The same kind of error, the folder named.
        let kept = format!(
            "{err}; what the script wrote before it is in {} (its manifest says failed)",
            out.display()
        );
        return Err(match err.downcast::<InputError>() {
            Ok(_) => InputError::new(kept).into(),
            Err(_) => anyhow!(kept),
        });
    }
    let r = recorder.borrow();
    let extra = serde_json::json!({
        "grid": r.grid(),
        "gases": r.gas_names(),
        "saved_frames": r.saved_frames,
        "files": r.files,
        "operations": used.get(),
        "wall_seconds": wall,
    });
    io::write_json(&manifest, &Manifest::new(&config, 0, wall, extra))?;
    let count = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    println!(
        "script {file}: {} saved, {} written in {wall:.1} s; wrote {}",
        count(r.saved_frames.len(), "frame"),
        count(r.files.len(), "array"),
        out.display()
    );
    Ok(())
}
