//! A map shared by several fields, evaluated once per batch.
//!
//! Several densities composed with the same map, `ρⱼ ∘ X` (the rows of the
//! sphere wall composed with one gridless or SELMA map, eqs 7.4 and 8.8),
//! are queried by the renderer one after another at the *same* batch of
//! points. [`Memo`] wraps the map and keeps, per thread, the last batch it
//! evaluated: when the next query is the same points (compared exactly), the
//! stored images are copied instead of walking the map again. Each memo has
//! its own id, so two memos never share an entry.

use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use glam::Vec3;

use super::{Vector, VectorField};

/// The last batch of one thread: the memo's id, the points and their images.
struct Entry {
    id: u64,
    points: Vec<Vec3>,
    images: Vec<Vec3>,
}

thread_local! {
    static LAST: RefCell<Entry> = const {
        RefCell::new(Entry {
            id: u64::MAX,
            points: Vec::new(),
            images: Vec::new(),
        })
    };
}

static NEXT_ID: AtomicU64 = AtomicU64::new(0);

/// A vector field whose last batch per thread is remembered.
pub struct Memo {
    inner: Vector,
    id: u64,
}

impl Memo {
    /// Remember the batches of `inner`.
    pub fn new(inner: Vector) -> Self {
        Self {
            inner,
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
        }
    }
}

/// `map` remembered per batch, shared.
pub fn memo(map: Vector) -> Vector {
    Arc::new(Memo::new(map))
}

impl VectorField for Memo {
    fn eval(&self, p: Vec3) -> Vec3 {
        self.inner.eval(p)
    }

    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        let hit = LAST.with(|last| {
            let e = last.borrow();
            let hit = e.id == self.id && e.points == points;
            if hit {
                out.copy_from_slice(&e.images);
            }
            hit
        });
        if hit {
            return;
        }
        // Evaluated outside the borrow: the inner map may hold memos itself.
        self.inner.eval_batch(points, out);
        LAST.with(|last| {
            let mut e = last.borrow_mut();
            e.id = self.id;
            e.points.clear();
            e.points.extend_from_slice(points);
            e.images.clear();
            e.images.extend_from_slice(out);
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicUsize;

    /// `x ↦ 2x`, counting its batches.
    struct Doubling(Arc<AtomicUsize>);
    impl VectorField for Doubling {
        fn eval(&self, p: Vec3) -> Vec3 {
            2.0 * p
        }
        fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
            self.0.fetch_add(1, Ordering::Relaxed);
            for (o, &p) in out.iter_mut().zip(points) {
                *o = 2.0 * p;
            }
        }
    }

    #[test]
    fn repeated_batches_are_evaluated_once_and_changed_ones_again() {
        let calls = Arc::new(AtomicUsize::new(0));
        let m = Memo::new(Arc::new(Doubling(calls.clone())));
        let other = Memo::new(Arc::new(Doubling(calls.clone())));
        let a = [Vec3::ONE, Vec3::X];
        let mut out = [Vec3::ZERO; 2];
        m.eval_batch(&a, &mut out);
        m.eval_batch(&a, &mut out);
        assert_eq!(calls.load(Ordering::Relaxed), 1);
        assert_eq!(out, [Vec3::splat(2.0), Vec3::new(2.0, 0.0, 0.0)]);
        // Another memo at the same points evaluates its own map.
        other.eval_batch(&a, &mut out);
        assert_eq!(calls.load(Ordering::Relaxed), 2);
        // Changed points are evaluated, not copied.
        let b = [Vec3::ONE, Vec3::Y];
        m.eval_batch(&b, &mut out);
        assert_eq!(calls.load(Ordering::Relaxed), 3);
        assert_eq!(out[1], Vec3::new(0.0, 2.0, 0.0));
    }

    #[test]
    fn a_memo_of_a_memo_evaluates_without_reentering_its_cache() {
        let calls = Arc::new(AtomicUsize::new(0));
        let inner = memo(Arc::new(Doubling(calls.clone())));
        let outer = Memo::new(inner);
        let a = [Vec3::ONE];
        let mut out = [Vec3::ZERO];
        outer.eval_batch(&a, &mut out);
        outer.eval_batch(&a, &mut out);
        assert_eq!(out, [Vec3::splat(2.0)]);
        assert_eq!(calls.load(Ordering::Relaxed), 1);
    }
}
