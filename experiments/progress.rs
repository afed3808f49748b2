//! Progress bars with an ETA on stderr for the commands that can take long
//! (`render`, `noise`, `experiment all`), with indicatif like `run`'s.
//!
//! A bar is hidden with `--quiet`, and indicatif draws nothing when stderr is
//! not a terminal, so test and CI output stays clean. The library has no
//! progress hooks, so `render` and `noise` count the points their fields are
//! asked for: [`Counted`] wraps a field, passes every query through
//! unchanged and advances the bar by the batch's size.

use std::sync::Arc;

use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};

use smokelab::field::{ScalarField, VectorField};

/// A bar of `len` units named `unit` (e.g. `"experiments"`), with elapsed
/// time and ETA; hidden unless `visible`.
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
