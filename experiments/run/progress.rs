//! Progress on stderr, with indicatif: for `run` and the experiments a
//! [`Stage`] with an ETA from a cost model that knows how a step's cost
//! grows ([`CostModel`]), inside an experiment one overall bar with named
//! stages ([`experiment`]); for `render` and `noise` a plain [`bar`] that
//! counts the points their fields are asked for ([`Counted`]).
//!
//! **The ETA.** A gridless step `k` advects the density back through all
//! `k` velocity grids before it, so its cost grows linearly in `k`: the
//! remaining time of a run at step `p` of `N` is `Σ_{k=p+1}^{N} (a + b k)`,
//! not `(N − p)` times the mean step so far (which read "1 s" from step 3
//! to step 54 of a 6 s gridless run). [`CostModel`] fits `a + b k` to the
//! measured step times by least squares ([`Growth::Linear`]), or `a` alone
//! ([`Growth::Constant`]: gridded and SELMA steps).
//!
//! **Experiments.** While an [`experiment`] guard lives, every [`stage`]
//! (each run of the experiment, named after its folder) draws into the
//! experiment's one bar instead of a bar of its own, so the bar does not
//! restart: it shows `stage i/n name`, the step in the stage, the stage's
//! ETA, and an overall ETA once the experiment has announced its stages
//! ([`plan`]). A planned stage not yet started is estimated from the
//! stages measured so far (same growth: their fitted cost per step;
//! otherwise a lower bound, shown as `≥`).
//!
//! A bar is hidden with `--quiet`, and indicatif draws nothing when stderr
//! is not a terminal, so test and CI output stays clean.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};

use smokelab::field::{ScalarField, VectorField};

/// A bar of `len` units named `unit` (e.g. `"samples"`), with elapsed
/// time and indicatif's ETA (constant cost per unit); hidden unless
/// `visible`.
pub fn bar(len: u64, unit: &str, visible: bool) -> ProgressBar {
    if !visible {
        return ProgressBar::hidden();
    }
    let template = format!(
        "{{elapsed_precise}} {{wide_bar}} {{human_pos}}/{{human_len}} {unit}, ETA {{eta}} {{msg}}"
    );
    ProgressBar::new(len)
        .with_style(ProgressStyle::with_template(&template).expect("a valid template"))
}

/// How the cost of step `k` grows with `k`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Growth {
    /// Every step costs about the same (gridded, SELMA).
    Constant,
    /// Step `k` costs `a + b k` (gridless: `k` velocity grids to walk back).
    Linear,
}

/// The cost of step `k`, `a + b k`, fitted by least squares to measured
/// step times (`b = 0` for [`Growth::Constant`]). With a linear growth
/// the fit keeps `a, b ≥ 0`: a negative slope falls back to the mean, a
/// negative intercept to the line through the origin (`t ∝ k`).
#[derive(Clone, Debug)]
pub struct CostModel {
    growth: Growth,
    n: f64,
    sk: f64,
    skk: f64,
    st: f64,
    skt: f64,
}

impl CostModel {
    /// A model with no measurements.
    pub fn new(growth: Growth) -> Self {
        Self {
            growth,
            n: 0.0,
            sk: 0.0,
            skk: 0.0,
            st: 0.0,
            skt: 0.0,
        }
    }

    /// The growth assumed.
    pub fn growth(&self) -> Growth {
        self.growth
    }

    /// Record that step `k` (1-based) took `seconds`.
    pub fn record(&mut self, k: u64, seconds: f64) {
        let k = k as f64;
        self.n += 1.0;
        self.sk += k;
        self.skk += k * k;
        self.st += seconds;
        self.skt += k * seconds;
    }

    /// Steps measured.
    pub fn samples(&self) -> u64 {
        self.n as u64
    }

    /// `(a, b)` with step `k` costing `a + b k`; `None` before any
    /// measurement.
    pub fn coefficients(&self) -> Option<(f64, f64)> {
        if self.n == 0.0 {
            return None;
        }
        let mean = self.st / self.n;
        if self.growth == Growth::Constant {
            return Some((mean, 0.0));
        }
        let var = self.skk - self.sk * self.sk / self.n;
        // One step index only: cost ∝ k through it.
        let through_origin = (0.0, self.skt / self.skk);
        if var <= 1e-9 * self.skk {
            return Some(through_origin);
        }
        let b = (self.skt - self.sk * self.st / self.n) / var;
        let a = mean - b * self.sk / self.n;
        Some(if b < 0.0 {
            (mean, 0.0)
        } else if a < 0.0 {
            through_origin
        } else {
            (a, b)
        })
    }

    /// Seconds steps `done + 1 ..= total` take: `Σ (a + b k)`; `None`
    /// before any measurement.
    pub fn remaining(&self, done: u64, total: u64) -> Option<f64> {
        let (a, b) = self.coefficients()?;
        Some(cost_between(a, b, done, total))
    }
}

/// `Σ_{k=done+1}^{total} (a + b k)`.
fn cost_between(a: f64, b: f64, done: u64, total: u64) -> f64 {
    if total <= done {
        return 0.0;
    }
    let (p, n) = (done as f64, total as f64);
    (n - p) * a + b * (n * (n + 1.0) - p * (p + 1.0)) / 2.0
}

/// `seconds` as `1h 02m`, `3m 07s` or `12s`.
pub fn human(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    match s {
        0..60 => format!("{s}s"),
        60..3600 => format!("{}m {:02}s", s / 60, s % 60),
        _ => format!("{}h {:02}m", s / 3600, s % 3600 / 60),
    }
}

/// One stage of an experiment as the overall bar knows it.
#[derive(Clone, Debug)]
struct StageInfo {
    name: String,
    len: u64,
    growth: Growth,
    /// Steps done and the model fitted so far (`None`: not started).
    progress: Option<(u64, CostModel)>,
    finished: bool,
}

/// The experiment being run and its stages.
struct Overall {
    title: String,
    bar: ProgressBar,
    stages: Vec<StageInfo>,
    /// Whether the stages were announced by [`plan`] (else the overall
    /// ETA is unknown: more stages may come).
    planned: bool,
    current: Option<usize>,
}

impl Overall {
    /// The overall ETA: the current stage's own, plus each planned stage
    /// estimated from those measured; `(seconds, lower bound only)`.
    fn eta(&self) -> Option<(f64, bool)> {
        let mut total = 0.0;
        let mut bound = false;
        let measured: Vec<&CostModel> = self
            .stages
            .iter()
            .filter_map(|s| s.progress.as_ref().map(|p| &p.1))
            .filter(|m| m.samples() > 0)
            .collect();
        for s in &self.stages {
            if s.finished {
                continue;
            }
            match &s.progress {
                Some((done, m)) if m.samples() > 0 => total += m.remaining(*done, s.len)?,
                _ => {
                    // Not started: like the measured stages of its growth,
                    // or at least as the constant ones.
                    let like: Vec<(f64, f64)> = measured
                        .iter()
                        .filter(|m| m.growth() == s.growth)
                        .filter_map(|m| m.coefficients())
                        .collect();
                    let (a, b) = if like.is_empty() {
                        bound = true;
                        let c: Vec<f64> = measured
                            .iter()
                            .filter_map(|m| m.coefficients())
                            .map(|(a, _)| a)
                            .collect();
                        if c.is_empty() {
                            return None;
                        }
                        (c.iter().sum::<f64>() / c.len() as f64, 0.0)
                    } else {
                        let n = like.len() as f64;
                        (
                            like.iter().map(|c| c.0).sum::<f64>() / n,
                            like.iter().map(|c| c.1).sum::<f64>() / n,
                        )
                    };
                    total += cost_between(a, b, 0, s.len);
                }
            }
        }
        Some((total, bound))
    }

    /// Redraw the bar: position in stages (per mille), the message.
    fn draw(&self) {
        let n = self.stages.len().max(1) as u64;
        let done: f64 = self
            .stages
            .iter()
            .map(|s| match (&s.progress, s.finished) {
                (_, true) => 1.0,
                (Some((d, _)), _) => *d as f64 / s.len.max(1) as f64,
                (None, _) => 0.0,
            })
            .sum();
        self.bar.set_length(1000 * n);
        self.bar.set_position((1000.0 * done) as u64);
        let mut msg = self.title.clone();
        if let Some(i) = self.current {
            let s = &self.stages[i];
            msg.push_str(&format!(
                " · stage {}/{} {}",
                i + 1,
                self.stages.len(),
                s.name
            ));
            if let Some((d, m)) = &s.progress {
                msg.push_str(&format!(" {d}/{}", s.len));
                if let Some(r) = m.remaining(*d, s.len) {
                    msg.push_str(&format!(", stage ETA {}", human(r)));
                }
            }
        }
        if self.planned {
            if let Some((eta, bound)) = self.eta() {
                msg.push_str(&format!(
                    " · ETA {}{}",
                    if bound { "≥ " } else { "" },
                    human(eta)
                ));
            }
        }
        self.bar.set_message(msg);
    }
}

/// The experiment whose stages draw into one bar, if one is running.
static OVERALL: Mutex<Option<Overall>> = Mutex::new(None);

fn overall() -> std::sync::MutexGuard<'static, Option<Overall>> {
    OVERALL.lock().unwrap_or_else(|e| e.into_inner())
}

/// Ends the experiment's overall bar when dropped.
pub struct ExperimentProgress {
    bar: ProgressBar,
}

impl ExperimentProgress {
    /// Run `f` with the bar out of the way (to print a line).
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        self.bar.suspend(f)
    }
}

impl Drop for ExperimentProgress {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
        *overall() = None;
    }
}

/// Start the overall bar of an experiment titled `title` (e.g. `06-5`),
/// hidden unless `visible`: until the guard is dropped, every [`stage`]
/// draws into it.
pub fn experiment(title: &str, visible: bool) -> ExperimentProgress {
    let bar = if visible {
        ProgressBar::new(1000).with_style(
            ProgressStyle::with_template("{elapsed_precise} {wide_bar} {msg}")
                .expect("a valid template"),
        )
    } else {
        ProgressBar::hidden()
    };
    bar.enable_steady_tick(Duration::from_secs(1));
    let o = Overall {
        title: title.to_string(),
        bar: bar.clone(),
        stages: vec![],
        planned: false,
        current: None,
    };
    o.draw();
    *overall() = Some(o);
    ExperimentProgress { bar }
}

/// Announce the stages the running experiment will run, in order:
/// `(name, steps, growth)`; the overall bar then counts them all and
/// shows an overall ETA. Nothing without an [`experiment`].
pub fn plan(stages: &[(&str, u64, Growth)]) {
    if let Some(o) = overall().as_mut() {
        for &(name, len, growth) in stages {
            o.stages.push(StageInfo {
                name: name.to_string(),
                len,
                growth,
                progress: None,
                finished: false,
            });
        }
        o.planned = true;
        o.draw();
    }
}

/// A stage of work: `len` steps whose cost grows as `growth`, with an ETA
/// from its [`CostModel`]; its own bar, or a stage of the running
/// [`experiment`]'s bar.
pub struct Stage {
    /// Its own bar (hidden inside an experiment).
    bar: ProgressBar,
    /// Index in the experiment's stages, if inside one.
    index: Option<usize>,
    model: CostModel,
    len: u64,
    pos: u64,
    last: Instant,
}

/// The name of the stage that writes into `out`: its folder's name.
pub fn stage_name(out: &std::path::Path) -> String {
    out.file_name()
        .map_or_else(|| "run".into(), |n| n.to_string_lossy().into_owned())
}

/// The growth of a run's step cost whose densities are held as `mode`.
pub fn growth_of(mode: smokelab::density::DensityMode) -> Growth {
    match mode {
        smokelab::density::DensityMode::Gridless => Growth::Linear,
        _ => Growth::Constant,
    }
}

/// A [`Stage`] named `name` (e.g. the run's folder) of `len` steps; hidden
/// unless `visible`.
pub fn stage(name: &str, len: u64, growth: Growth, visible: bool) -> Stage {
    let mut guard = overall();
    let (bar, index) = match guard.as_mut() {
        Some(o) => {
            // The first planned stage of this name not started, else a new one.
            let i = o
                .stages
                .iter()
                .position(|s| s.name == name && s.progress.is_none() && !s.finished)
                .unwrap_or_else(|| {
                    o.stages.push(StageInfo {
                        name: name.to_string(),
                        len,
                        growth,
                        progress: None,
                        finished: false,
                    });
                    o.stages.len() - 1
                });
            let s = &mut o.stages[i];
            s.len = len;
            s.growth = growth;
            s.progress = Some((0, CostModel::new(growth)));
            o.current = Some(i);
            o.draw();
            (ProgressBar::hidden(), Some(i))
        }
        None if visible => {
            let template =
                "{elapsed_precise} {wide_bar} {human_pos}/{human_len} steps, ETA {prefix} {msg}";
            let bar = ProgressBar::new(len)
                .with_style(ProgressStyle::with_template(template).expect("a valid template"));
            bar.set_prefix("…");
            (bar, None)
        }
        None => (ProgressBar::hidden(), None),
    };
    Stage {
        bar,
        index,
        model: CostModel::new(growth),
        len,
        pos: 0,
        last: Instant::now(),
    }
}

impl Stage {
    /// Start at step `pos` (a resumed run), without measuring.
    pub fn set_position(&mut self, pos: u64) {
        self.pos = pos;
        self.bar.set_position(pos);
        self.last = Instant::now();
        self.publish();
    }

    /// `n` more steps done, the time since the last call shared among them.
    pub fn inc(&mut self, n: u64) {
        if n == 0 {
            return;
        }
        let now = Instant::now();
        let each = (now - self.last).as_secs_f64() / n as f64;
        for _ in 0..n {
            self.pos += 1;
            self.model.record(self.pos, each);
        }
        self.last = now;
        self.bar.set_position(self.pos);
        if let Some(r) = self.model.remaining(self.pos, self.len) {
            self.bar.set_prefix(human(r));
        }
        self.publish();
    }

    /// Seconds left by the cost model (`None` before the first step).
    pub fn eta(&self) -> Option<f64> {
        self.model.remaining(self.pos, self.len)
    }

    fn publish(&self) {
        if let Some(i) = self.index {
            if let Some(o) = overall().as_mut() {
                if let Some(s) = o.stages.get_mut(i) {
                    s.progress = Some((self.pos, self.model.clone()));
                }
                o.draw();
            }
        }
    }

    /// A note after the counts (e.g. `max|u| 0.31`; own bar only).
    pub fn set_message(&self, msg: impl Into<std::borrow::Cow<'static, str>>) {
        self.bar.set_message(msg);
    }

    /// Run `f` with the bar out of the way (to print a line).
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        match self.index {
            Some(_) => {
                let bar = overall().as_ref().map(|o| o.bar.clone());
                match bar {
                    Some(b) => b.suspend(f),
                    None => f(),
                }
            }
            None => self.bar.suspend(f),
        }
    }

    /// Whether nothing is drawn for this stage on its own.
    pub fn is_hidden(&self) -> bool {
        self.bar.is_hidden()
    }

    fn end(&self) {
        if let Some(i) = self.index {
            if let Some(o) = overall().as_mut() {
                if let Some(s) = o.stages.get_mut(i) {
                    s.finished = true;
                    s.progress = Some((self.pos, self.model.clone()));
                }
                o.current = None;
                o.draw();
            }
        }
    }

    /// The stage is done: clear its bar.
    pub fn finish_and_clear(&self) {
        self.end();
        self.bar.finish_and_clear();
    }

    /// The stage stopped on an error: leave its bar as it is.
    pub fn abandon(&self) {
        self.end();
        self.bar.abandon();
    }
}

/// A field that advances a bar by every point it is evaluated at, and
/// otherwise is `inner`: a [`ScalarField`] for `F = dyn ScalarField`, a
/// [`VectorField`] for `F = dyn VectorField`.
pub struct Counted<F: ?Sized> {
    inner: Arc<F>,
    bar: ProgressBar,
}

impl<F: ?Sized> Counted<F> {
    /// `inner`, counting its queries on `bar`.
    pub fn new(inner: Arc<F>, bar: &ProgressBar) -> Self {
        Self {
            inner,
            bar: bar.clone(),
        }
    }
}

impl ScalarField for Counted<dyn ScalarField> {
    fn eval(&self, p: Vec3) -> f32 {
        self.bar.inc(1);
        self.inner.eval(p)
    }

    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        self.inner.eval_batch(points, out);
        self.bar.inc(points.len() as u64);
    }

    fn grad_batch(&self, points: &[Vec3], out: &mut [Vec3]) -> bool {
        self.inner.grad_batch(points, out)
    }
}

impl VectorField for Counted<dyn VectorField> {
    fn eval(&self, p: Vec3) -> Vec3 {
        self.bar.inc(1);
        self.inner.eval(p)
    }

    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        self.inner.eval_batch(points, out);
        self.bar.inc(points.len() as u64);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A gridless-like run: step k takes 0.01 k s (plus 5 % noise).
    fn linear_run(model: &mut CostModel, steps: u64) {
        for k in 1..=steps {
            let noise = 1.0 + 0.05 * ((k * 7919 % 13) as f64 / 6.0 - 1.0);
            model.record(k, 0.01 * k as f64 * noise);
        }
    }

    #[test]
    fn linear_growth_sums_the_remaining_steps() {
        let mut m = CostModel::new(Growth::Linear);
        linear_run(&mut m, 10);
        // Σ_{k=11}^{100} 0.01 k = 49.95 s; the mean so far times 90 is 4.95 s.
        let eta = m.remaining(10, 100).unwrap();
        assert!((eta / 49.95 - 1.0).abs() < 0.05, "{eta}");
        let mut naive = CostModel::new(Growth::Constant);
        linear_run(&mut naive, 10);
        assert!(naive.remaining(10, 100).unwrap() < 0.11 * eta);
        // One step measured: cost ∝ k through it.
        let mut one = CostModel::new(Growth::Linear);
        one.record(3, 0.03);
        assert!((one.remaining(3, 6).unwrap() - 0.15).abs() < 1e-9);
    }

    #[test]
    fn constant_growth_is_the_mean_and_noise_keeps_the_fit_sane() {
        let mut m = CostModel::new(Growth::Constant);
        for k in 1..=20 {
            m.record(k, if k % 2 == 0 { 0.9 } else { 1.1 });
        }
        assert!((m.remaining(20, 50).unwrap() - 30.0).abs() < 1e-9);
        // A linear model on constant steps finds no slope.
        let mut l = CostModel::new(Growth::Linear);
        for k in 1..=20 {
            l.record(k, 1.0);
        }
        let (a, b) = l.coefficients().unwrap();
        assert!((a - 1.0).abs() < 1e-9 && b.abs() < 1e-9, "{a} {b}");
        // Falling step times: the slope is clamped, the mean taken.
        let mut f = CostModel::new(Growth::Linear);
        for k in 1..=10 {
            f.record(k, 2.0 - 0.1 * k as f64);
        }
        assert_eq!(f.coefficients().unwrap().1, 0.0);
        assert!(CostModel::new(Growth::Linear).remaining(0, 10).is_none());
        assert_eq!(m.remaining(50, 50), Some(0.0));
    }

    #[test]
    fn the_overall_eta_adds_planned_stages_estimated_from_measured_ones() {
        let measured = |growth, steps, f: &dyn Fn(u64) -> f64| {
            let mut m = CostModel::new(growth);
            for k in 1..=steps {
                m.record(k, f(k));
            }
            m
        };
        let info = |name: &str, len, growth, progress, finished| StageInfo {
            name: name.into(),
            len,
            growth,
            progress,
            finished,
        };
        let mut o = Overall {
            title: "t".into(),
            bar: ProgressBar::hidden(),
            stages: vec![
                // Done: 60 gridded steps of 0.1 s.
                info(
                    "gridded",
                    60,
                    Growth::Constant,
                    Some((60, measured(Growth::Constant, 60, &|_| 0.1))),
                    true,
                ),
                // Half-way: gridless, 0.01 k s.
                info(
                    "gridless",
                    60,
                    Growth::Linear,
                    Some((30, measured(Growth::Linear, 30, &|k| 0.01 * k as f64))),
                    false,
                ),
                info("selma", 60, Growth::Constant, None, false),
            ],
            planned: true,
            current: Some(1),
        };
        let (eta, bound) = o.eta().unwrap();
        // Gridless: Σ_{31}^{60} 0.01 k = 13.65 s; SELMA like gridded: 6 s.
        assert!((eta - 19.65).abs() < 1e-6, "{eta}");
        assert!(!bound);
        // A gridless stage planned before any was measured: a lower bound.
        o.stages[1].progress = None;
        o.stages[1].growth = Growth::Linear;
        o.stages.swap(1, 2);
        o.stages[1].progress = Some((60, measured(Growth::Constant, 60, &|_| 0.1)));
        o.stages[1].finished = true;
        let (eta, bound) = o.eta().unwrap();
        assert!(bound && (eta - 6.0).abs() < 1e-6, "{eta}");
        o.draw();
    }

    #[test]
    fn durations_read_as_people_write_them() {
        assert_eq!(human(12.4), "12s");
        assert_eq!(human(187.0), "3m 07s");
        assert_eq!(human(3720.0), "1h 02m");
    }
}
