//! `smokelab run --resume RUN_DIR`: continue a killed or complete run from
//! its `checkpoint.bin`, after checking the checkpoint whole, of this
//! build, and matching the run's manifest and metrics rows; only
//! `--frames`, `--threads` and `--quiet` may be given beside it.

use std::path::PathBuf;

use anyhow::Result;

use crate::cli::process::{init_threads, set_running};
use crate::cli::run::{frame_render, run_options, scenario_keys, RunArgs};
use crate::run::checkpoint::{Checkpoint, RunRecord};
use crate::run::output_dir;
use crate::run::{self, Checkpointing};
use smokelab::error::InputError;
use smokelab::io;
use smokelab::scenario::{config, Scenario};

/// `smokelab run --resume RUN_DIR`: check everything (the checkpoint whole,
/// of this version, matching the run's manifest and its metrics rows), then
/// remove the frames written after the checkpoint, cut `metrics.csv` after
/// its row and continue the run from it.
pub(crate) fn resume_run(args: &RunArgs, dir: &std::path::Path) -> Result<()> {
    let mut given = args.solver.overrides();
    given.extend(toml::Table::try_from(&args.scene).expect("flags serialize to a table"));
    given.remove("frames");
    given.remove("threads");
    let others = [
        (args.config.is_some(), "--config"),
        (!args.set.is_empty(), "--set"),
        (args.out.is_some(), "--out"),
        (args.overwrite, "--overwrite"),
        (args.print_config, "--print-config"),
        (args.checkpoint_every.is_some(), "--checkpoint-every"),
        (
            args.vdb || args.paraview || args.render || args.vdb_flags.given(),
            "output flags",
        ),
    ];
    let mut refused: Vec<String> = given
        .keys()
        .map(|k| format!("--{}", k.replace('_', "-")))
        .collect();
    refused.extend(others.iter().filter(|o| o.0).map(|o| o.1.to_string()));
    if !refused.is_empty() {
        return Err(InputError::new(format!(
            "--resume continues the run as it was configured; drop {} (only --frames, --threads and --quiet may be given)",
            refused.join(", ")
        ))
        .into());
    }
    if !dir.is_dir() {
        return Err(
            InputError::new(format!("--resume {} is not a run folder", dir.display())).into(),
        );
    }
    io::folder::check_free(dir)?;
    if io::folder::read_record(dir)?.is_none() {
        return Err(InputError::new(format!(
            "{} has no record of the files smokelab wrote there ({}; a smokelab older than 0.4 kept none); resuming would replace files by their names: start the run again instead",
            dir.display(),
            io::folder::RECORD
        ))
        .into());
    }
    let checkpoint = Checkpoint::read(dir)?;
    if checkpoint.commit() != io::manifest::BUILD_COMMIT {
        eprintln!(
            "warning: {} was written by a build of {}; this is {}: a resumed run is bitwise the uninterrupted one only on the same build",
            dir.join(crate::run::checkpoint::FILE).display(),
            checkpoint.commit(),
            io::manifest::BUILD_COMMIT
        );
    }
    smokelab::with_scenario!(checkpoint.run().scenario, C => {
        resume_config::<C>(args, dir, checkpoint)
    })
}

/// [`resume_run`] for the checkpoint's scenario `C`.
fn resume_config<C: Scenario>(
    args: &RunArgs,
    dir: &std::path::Path,
    checkpoint: Checkpoint,
) -> Result<()> {
    let record = checkpoint.run().clone();
    let step = checkpoint.step();
    let file = dir.join(crate::run::checkpoint::FILE);
    let recorded: toml::Table = toml::from_str(&record.config).map_err(|e| {
        InputError::new(format!(
            "{} holds a configuration that does not parse: {e}",
            file.display()
        ))
    })?;
    let original: C =
        config::resolve(&[("checkpoint".into(), recorded.clone())], &scenario_keys())?;
    let manifest = checked_manifest(dir, &file, &original)?;
    // `frames` is the one key a resume changes (`--frames N`); the
    // manifest's is the count last asked for.
    let asked_frames = manifest["config"].get("frames").and_then(|f| f.as_u64());
    if manifest["status"] == "complete" && args.solver.frames.is_none() {
        return Err(InputError::new(format!(
            "the run in {} is complete; give --frames N (more than the checkpoint's step {step}) to continue it",
            dir.display()
        ))
        .into());
    }
    let mut layers = vec![("checkpoint".to_string(), recorded)];
    let frames = args
        .solver
        .frames
        .or(asked_frames.and_then(|f| usize::try_from(f).ok()));
    if let Some(frames) = frames {
        let mut t = toml::Table::new();
        t.insert("frames".into(), toml::Value::Integer(frames as i64));
        let from = if args.solver.frames.is_some() {
            "--frames"
        } else {
            "manifest"
        };
        layers.push((from.into(), t));
    }
    let config: C = config::resolve(&layers, &scenario_keys())?;
    let s = config.solver();
    if s.frames <= step {
        return Err(InputError::new(format!(
            "the run would end at frame {}, not after the checkpoint's step {step}; give --frames N > {step}",
            s.frames
        ))
        .into());
    }
    init_threads(args.solver.threads.or(s.threads))?;
    let flags = RunArgs {
        render: record.render.is_some(),
        render_every: record.render.as_ref().and_then(|r| r.every),
        image: record.render.as_ref().and_then(|r| r.image.clone()),
        march_step: record.render.as_ref().and_then(|r| r.march_step),
        ..RunArgs::default()
    };
    let render = frame_render(&flags, s)?;
    let mut sim = config.build()?;
    sim.restore(checkpoint.into_state()).map_err(|e| {
        InputError::new(format!(
            "{} does not fit the simulation its configuration builds: {e}",
            file.display()
        ))
    })?;
    let metrics = crate::run::checkpoint::metrics_upto(dir, step, &run::metric_columns(&sim))?;
    // Checked: now hold the folder and replace what the killed run wrote
    // after the checkpoint (only files the record names as smokelab's).
    let folder = io::folder::OutputFolder::open(dir)?;
    let save_every = s.save_every;
    let mut after = Vec::new();
    for f in folder.entries() {
        let name = f.as_str();
        let number = name
            .rsplit_once('_')
            .and_then(|(_, rest)| rest.split_once('.'))
            .and_then(|(n, _)| n.parse::<usize>().ok());
        // The VDB and VTK frames are numbered by sequence: `n` holds a step
        // in `((n−1)K, nK]`, after the checkpoint when `nK > step` (the one
        // straddling it is rewritten by the resumed run).
        let exchange =
            name.starts_with("frame_") && (name.ends_with(".vdb") || name.ends_with(".vti"));
        let later = !name.contains('/')
            && output_dir::is_frame_file(name, &["npy", "png", "exr", "vdb", "vti"])
            && number.is_some_and(|n| match exchange {
                true => n * save_every.max(1) > step,
                false => n > step,
            });
        if later {
            after.push(f);
        }
    }
    folder.remove(&after)?;
    for f in killed_temporary_files(dir) {
        std::fs::remove_file(&f)
            .map_err(|e| anyhow::anyhow!("cannot remove {} to resume: {e}", f.display()))?;
    }
    io::write_atomic(&dir.join("metrics.csv"), |w| {
        use std::io::Write;
        Ok(w.write_all(metrics.as_bytes())?)
    })?;
    set_running(dir, true);
    let vdb = record.vdb.then(|| record.vdb_frames.clone());
    let opts = run_options(
        dir.to_path_buf(),
        s,
        args.quiet,
        render,
        (vdb, record.paraview),
    );
    let checkpoints = Checkpointing {
        every: record.checkpoint_every,
        record: RunRecord {
            config: toml::to_string(&config).expect("a configuration serializes to TOML"),
            ..record
        },
        resumed_from: Some(step),
    };
    let summary = run::run_checkpointed(&mut sim, &opts, &config, s.seed, &checkpoints)?;
    println!(
        "{} ({} density): resumed at step {step}, {} steps at {}³ in {:.1} s; wrote {}",
        C::NAME,
        s.density,
        s.frames - step,
        s.res,
        summary.wall_seconds,
        dir.display()
    );
    Ok(())
}

/// The run's `manifest.json` in `dir`, checked to name the configuration
/// `original` the checkpoint `file` holds (the manifest is written at the
/// run's start).
fn checked_manifest<C: Scenario>(
    dir: &std::path::Path,
    file: &std::path::Path,
    original: &C,
) -> Result<serde_json::Value> {
    let manifest_path = dir.join("manifest.json");
    let manifest: serde_json::Value = std::fs::read(&manifest_path)
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .ok_or_else(|| {
            InputError::new(format!(
                "{} is missing or not JSON; cannot check the checkpoint against the run",
                manifest_path.display()
            ))
        })?;
    // Through text, as the manifest was written (an f32 as its shortest decimal).
    let mut want: serde_json::Value = serde_json::from_str(&serde_json::to_string(&original)?)?;
    let mut have = manifest["config"].clone();
    // `frames` is the one key a resume changes (`--frames N`): a resume
    // interrupted before its first checkpoint left the new count in the
    // manifest and the old one in the checkpoint.
    for config in [&mut want, &mut have] {
        if let Some(c) = config.as_object_mut() {
            c.remove("frames");
        }
    }
    if have != want {
        let differ: Vec<&String> = want
            .as_object()
            .map(|w| {
                w.keys()
                    .filter(|k| have[k.as_str()] != w[k.as_str()])
                    .collect()
            })
            .unwrap_or_default();
        return Err(InputError::new(format!(
            "{} is from another configuration than {} (keys differing: {})",
            file.display(),
            manifest_path.display(),
            if differ.is_empty() {
                "all".to_string()
            } else {
                differ
                    .iter()
                    .map(|k| k.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            }
        ))
        .into());
    }
    Ok(manifest)
}

/// Temporary files a killed process left in `dir`:
/// `.<name>.XXXXXX.smokelab-tmp` ([`io::write_atomic`]; a SIGKILL leaves no
/// time to remove them). Called with the folder's lock held, so none is
/// another writer's.
fn killed_temporary_files(dir: &std::path::Path) -> Vec<PathBuf> {
    let is_temporary = io::is_temporary_file;
    std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .filter(|e| e.file_name().to_str().is_some_and(is_temporary))
        .map(|e| e.path())
        .collect()
}
