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
//! are reported as `FILE:LINE:COL: message`.

pub mod functions;
pub mod map;
pub mod output;
pub mod types;

#[cfg(test)]
mod tests;

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::time::Instant;

use anyhow::Result;
use clap::Args;
use rhai::{Dynamic, Engine, EvalAltResult, Position, Scope, FLOAT, INT};
use serde::Serialize;
use smokelab::error::InputError;
use smokelab::io::{self, manifest::Manifest};
use smokelab::pressure::PressurePrecision;

use output::Recorder;

/// `smokelab script`.
#[derive(Debug, Args)]
pub struct ScriptArgs {
    /// The script (`experiments/scripts/*.rhai`).
    pub file: PathBuf,
    /// Override a `param("name", default)` of the script, e.g. `--set res=32` (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// Output folder (default `runs/script-<file stem>`); the script writes only inside it.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace an earlier run's outputs in the folder (frames, arrays,
    /// metrics, manifest); without it such a folder is refused.
    #[arg(long)]
    pub overwrite: bool,
    /// Transforms of every `domain`'s pressure solve (`fftdivfree`, `diffuse`): f32 (default) or f64, as `smokelab run --pressure-precision`.
    #[arg(long, value_enum, default_value_t)]
    pub pressure_precision: PressurePrecision,
}

/// What the manifest records as the run's configuration.
#[derive(Serialize)]
struct ScriptConfig {
    script: String,
    /// The transforms of every `domain`'s pressure solve.
    pressure_precision: PressurePrecision,
    /// Every `param` the script read, as it resolved.
    params: BTreeMap<String, String>,
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

/// `FILE:LINE:COL: message`.
fn located(file: &str, pos: Position, message: impl std::fmt::Display) -> InputError {
    match (pos.line(), pos.position()) {
        (Some(l), Some(c)) => InputError::new(format!("{file}:{l}:{c}: {message}")),
        (Some(l), None) => InputError::new(format!("{file}:{l}: {message}")),
        _ => InputError::new(format!("{file}: {message}")),
    }
}

/// The engine with every type, function and writer registered.
fn engine(
    recorder: &Rc<RefCell<Recorder>>,
    params: &Rc<RefCell<Params>>,
    precision: PressurePrecision,
) -> Engine {
    let mut engine = Engine::new();
    types::register(&mut engine);
    functions::register(&mut engine, precision);
    map::register(&mut engine);
    output::register(&mut engine, recorder);
    let p = params.clone();
    engine.register_fn("param", move |name: &str, default: Dynamic| {
        let mut p = p.borrow_mut();
        let value = match p.set.get(name) {
            Some(v) => parse_as(name, v, &default)?,
            None => default,
        };
        p.read.insert(name.to_string(), value.to_string());
        Ok::<_, Box<EvalAltResult>>(value)
    });
    engine
}

/// Run a script: parse, check the `--set` names, evaluate, write the manifest.
pub fn run(args: &ScriptArgs) -> Result<()> {
    let file = args.file.display().to_string();
    let source = std::fs::read_to_string(&args.file)
        .map_err(|e| InputError::new(format!("cannot read {file}: {e}")))?;
    let params = Rc::new(RefCell::new(Params {
        set: parse_sets(&args.set, &declared_params(&source), &file)?,
        read: BTreeMap::new(),
    }));
    let out = args.out.clone().unwrap_or_else(|| {
        let stem = args
            .file
            .file_stem()
            .map_or("script".into(), |s| s.to_string_lossy());
        Path::new("runs").join(format!("script-{stem}"))
    });
    let _folder =
        crate::run::output_dir::prepare(&out, &crate::run::output_dir::SCRIPT, args.overwrite)?;
    let recorder = Rc::new(RefCell::new(Recorder::new(out.clone())));
    let engine = engine(&recorder, &params, args.pressure_precision);
    let ast = engine
        .compile(&source)
        .map_err(|e| located(&file, e.1, &e.0))?;
    let start = Instant::now();
    let result = engine.run_ast_with_scope(&mut Scope::new(), &ast);
    let config = ScriptConfig {
        script: file.clone(),
        pressure_precision: args.pressure_precision,
        params: params.borrow().read.clone(),
    };
    let wall = start.elapsed().as_secs_f64();
    let manifest = out.join("manifest.json");
    if let Err(mut e) = result {
        let pos = e.take_position();
        let err = located(&file, pos, &e);
        io::write_json(
            &manifest,
            &Manifest::failed(&config, 0, wall, err.to_string()),
        )?;
        return Err(err.into());
    }
    let r = recorder.borrow();
    let extra = serde_json::json!({
        "grid": r.grid(),
        "gases": r.gas_names(),
        "saved_frames": r.saved_frames,
        "files": r.files,
        "wall_seconds": wall,
    });
    io::write_json(&manifest, &Manifest::new(&config, 0, wall, extra))?;
    Ok(())
}
