//! The script's types and their operators.
//!
//! | script type | holds | notes' meaning |
//! |---|---|---|
//! | `scalarfield` | [`Scalar`] (`Arc<dyn ScalarField>`) | a scalar function of position |
//! | `vectorfield` | [`Vector`] | a vector function of position |
//! | `matrixfield` | [`Matrix`] | a 3 × 3 matrix function (`grad(grad(ℓ))`) |
//! | `scalarcache` | a named [`ScalarGrid`] at the cell centres | `scalarcache hotCache(region)` |
//! | `vectorcache` | a [`FaceGrid`], the MAC velocity | the gridded velocity `fftdivfree` returns |
//! | `mapcache` | [`super::map::MapCache`], the displacement `X − x` at the cell centres | SELMA's `XmapCache` (ch. 8) |
//! | `domain` | a [`Domain`], periodic or closed, its pressure solver and backtrace | `region` |
//! | `vector` | a constant [`Vec3`] | `vector hotpoint = …` |
//!
//! Every operator builds a node of the library's field graph (or, for
//! caches, does one native pass over a grid); nothing here is called per
//! point. Operators (all overloaded for `float` and `int` numbers):
//! `+ − * /` between fields, fields and numbers, caches and numbers
//! (`vectorcache * k` scales every face); unary
//! `−`; `vectorfield * vectorfield` is the dot product (the notes'
//! `spherecenter*spherecenter`), `vectorfield * matrixfield` the row vector
//! `vᵀM`, so `B*M*B` is eq 4.9's `B·M·B`; `^` and `**` are the power (the
//! notes' `(…)^0.5`, eq 4.7). Rhai parses `^` at the precedence of its
//! exclusive or, looser than `+ −`: `a + b^0.5` is `(a + b)^0.5`. Scripts
//! write `**`, Rhai's power operator, which binds tighter than `*`.
//!
//! A velocity cache meets a vectorfield as the notes write it: `velocity +
//! v` and `velocity − v` sample `v` at the face centres (component `a` at
//! the `a`-faces), `velocity * n` is the dot product of the cache's point
//! query with `n`.
//!
//! Caches are immutable values shared by [`Arc`]: an operation makes a new
//! grid (one allocation per grid per step, none per cell), so a script's
//! `hot = …` rebinding never aliases another variable's grid.

use std::cell::RefCell;
use std::rc::Rc;
use std::sync::Arc;

use glam::Vec3;
use rayon::prelude::*;
use rhai::{Engine, EvalAltResult, FLOAT, INT};
use smokelab::advection::Backtrace;
use smokelab::density::probe::cell_averages;
use smokelab::domain::Domain;
use smokelab::field::algebra::{self as fa, Matrix};
use smokelab::field::{ops, Scalar, Vector, VectorField};
use smokelab::grid::{BoxKind, FaceGrid, ScalarGrid};
use smokelab::pressure::{PressurePrecision, PressureSolver};
use smokelab::simulation::SOURCE_REFINE;

/// A native function's failure, shown with the script's position.
pub type Fallible<T> = Result<T, Box<EvalAltResult>>;

/// A script's time step `dt` given to `what`, as the f32 the verbs take;
/// refused unless finite (in f32 too: `1e39` is not).
pub fn time_step(what: &str, dt: FLOAT) -> Fallible<f32> {
    let t = dt as f32;
    if t.is_finite() {
        Ok(t)
    } else {
        Err(format!("{what}: the time step is {dt}; it must be a finite number").into())
    }
}

/// A field's cell averages on one domain, once computed.
type Averages = Option<(Domain, Arc<ScalarGrid>)>;

/// A scalar field, with its cell averages on one domain kept once computed
/// (the injection rate a cache adds every step, see [`ScalarCache`]'s `+`).
#[derive(Clone)]
pub struct ScalarF {
    /// The field.
    pub field: Scalar,
    averages: Rc<RefCell<Averages>>,
}

impl ScalarF {
    /// Wrap a field.
    pub fn new(field: Scalar) -> Self {
        Self {
            field,
            averages: Rc::default(),
        }
    }

    /// The field's averages over the cells of `domain` by
    /// [`SOURCE_REFINE`]³ sub-cells — the gridded injection of
    /// [`smokelab::simulation::Gas`] — computed once per domain.
    fn cell_averages(&self, domain: &Domain) -> Arc<ScalarGrid> {
        let mut kept = self.averages.borrow_mut();
        match &*kept {
            Some((d, g)) if d == domain => g.clone(),
            _ => {
                let g = Arc::new(cell_averages(&*self.field, domain, SOURCE_REFINE));
                *kept = Some((*domain, g.clone()));
                g
            }
        }
    }
}

/// A vector field.
#[derive(Clone)]
pub struct VectorF(pub Vector);

/// A matrix field.
#[derive(Clone)]
pub struct MatrixF(pub Matrix);

/// A scalar cache: a density at the cell centres, named for its output files.
#[derive(Clone)]
pub struct ScalarCache {
    /// Output name (`<name>_NNNN.npy`).
    pub name: String,
    /// The samples.
    pub grid: Arc<ScalarGrid>,
}

/// A vector cache: the staggered (MAC) velocity.
#[derive(Clone)]
pub struct VectorCache(pub Arc<FaceGrid>);

/// The notes' `region`: a periodic or closed box, its pressure solver
/// (planned once) and the backtrace of the semi-Lagrangian `advect`.
#[derive(Clone)]
pub struct Region {
    /// The box.
    pub domain: Domain,
    /// Periodic, or closed (walls with no normal flow, densities read
    /// clamped to the box) — `smokelab run --box`.
    pub kind: BoxKind,
    /// How `advect` traces departure points on a velocity cache.
    pub backtrace: Backtrace,
    /// The exact pressure solve of `fftdivfree`.
    pub solver: Rc<RefCell<PressureSolver>>,
}

impl Region {
    /// A region of `kind` over `domain`, tracing with RK2 (the run's
    /// default) and solving the pressure in `precision`.
    pub fn new(domain: Domain, kind: BoxKind, precision: PressurePrecision) -> Self {
        Self {
            domain,
            kind,
            backtrace: Backtrace::default(),
            solver: Rc::new(RefCell::new(PressureSolver::with_precision(
                domain, kind, precision,
            ))),
        }
    }
}

/// A constant vector.
#[derive(Clone, Copy)]
pub struct V3(pub Vec3);

/// `vᵀ M`: a vector field times a matrix field, so that `(B*M)*B = B·M·B`.
struct RowTimes(Vector, Matrix);

impl VectorField for RowTimes {
    fn eval(&self, p: Vec3) -> Vec3 {
        self.1.eval(p).transpose() * self.0.eval(p)
    }
}

/// Elementwise `a op b` of two caches on one domain, in place when `a`'s
/// grid is not shared (a temporary such as `advect(hot, …)`).
fn zip_caches(
    mut a: ScalarCache,
    b: &ScalarCache,
    op: fn(f32, f32) -> f32,
) -> Fallible<ScalarCache> {
    if a.grid.domain() != b.grid.domain() {
        return Err(format!(
            "scalarcache `{}` and `{}` are on different domains",
            a.name, b.name
        )
        .into());
    }
    Arc::make_mut(&mut a.grid)
        .as_slice_mut()
        .par_iter_mut()
        .zip(b.grid.as_slice().par_iter())
        .for_each(|(o, &v)| *o = op(*o, v));
    Ok(a)
}

/// `f(c)` for every sample of a cache (in place when not shared).
fn map_cache(mut a: ScalarCache, f: impl Fn(f32) -> f32 + Sync) -> ScalarCache {
    Arc::make_mut(&mut a.grid)
        .as_slice_mut()
        .par_iter_mut()
        .for_each(|v| *v = f(*v));
    a
}

/// `k u` on every face (in place when `a` is not shared).
fn scale_faces(mut a: VectorCache, k: f32) -> VectorCache {
    let out = Arc::make_mut(&mut a.0);
    for axis in 0..3 {
        out.slice_mut(axis).par_iter_mut().for_each(|v| *v *= k);
    }
    a
}

/// Face by face `a op b` of two velocity caches (in place when `a` is not shared).
fn zip_faces(mut a: VectorCache, b: &FaceGrid, op: fn(f32, f32) -> f32) -> Fallible<VectorCache> {
    if a.0.domain() != b.domain() || a.0.kind() != b.kind() {
        return Err("vectorcache operands are on different domains".into());
    }
    let out = Arc::make_mut(&mut a.0);
    for axis in 0..3 {
        out.slice_mut(axis)
            .par_iter_mut()
            .zip(b.slice(axis).par_iter())
            .for_each(|(o, &v)| *o = op(*o, v));
    }
    Ok(a)
}

/// `k c` on the faces: the buoyancy of eq 6.5 as the library forms it
/// ([`smokelab::forces::face_force`]), so `velocity + dt*gravity*(cold −
/// hot)` is bit for bit the step's `u −= Δt g⃗ (hot − cold)`.
pub fn force_on_faces(k: Vec3, c: &ScalarGrid) -> VectorCache {
    VectorCache(Arc::new(smokelab::forces::face_force(k, c)))
}

/// `velocity + s`: the injection of eq 6.4 when `s` is a field (its cell
/// averages, the library's quadrature of the source, kept on the field).
fn cache_plus_field(a: ScalarCache, s: &ScalarF) -> Fallible<ScalarCache> {
    let grid = s.cell_averages(a.grid.domain());
    let name = a.name.clone();
    zip_caches(a, &ScalarCache { name, grid }, |x, y| x + y)
}

/// Register the types, their names in messages, and every operator.
pub fn register(engine: &mut Engine) {
    engine
        .register_type_with_name::<ScalarF>("scalarfield")
        .register_type_with_name::<VectorF>("vectorfield")
        .register_type_with_name::<MatrixF>("matrixfield")
        .register_type_with_name::<ScalarCache>("scalarcache")
        .register_type_with_name::<VectorCache>("vectorcache")
        .register_type_with_name::<Region>("domain")
        .register_type_with_name::<V3>("vector");
    let sf = |f: Scalar| ScalarF::new(f);
    let num = |x: f32| ops::constant(x);

    // scalarfield ∘ scalarfield
    engine.register_fn("+", move |a: ScalarF, b: ScalarF| {
        sf(fa::add(a.field, b.field))
    });
    engine.register_fn("-", move |a: ScalarF, b: ScalarF| {
        sf(fa::sub(a.field, b.field))
    });
    engine.register_fn("*", move |a: ScalarF, b: ScalarF| {
        sf(fa::mul(a.field, b.field))
    });
    engine.register_fn("/", move |a: ScalarF, b: ScalarF| {
        sf(fa::div(a.field, b.field))
    });
    engine.register_fn("^", move |a: ScalarF, b: ScalarF| {
        sf(fa::pow_field(a.field, b.field))
    });
    engine.register_fn("-", move |a: ScalarF| sf(fa::neg(a.field)));

    // vectorfield
    engine.register_fn("+", |a: VectorF, b: VectorF| {
        VectorF(ops::vector_sum(a.0, b.0))
    });
    engine.register_fn("-", |a: VectorF, b: VectorF| {
        VectorF(fa::vector_sub(a.0, b.0))
    });
    engine.register_fn("-", |a: VectorF| VectorF(ops::vector_scale(a.0, -1.0)));
    engine.register_fn("*", move |a: VectorF, b: VectorF| sf(fa::dot(a.0, b.0)));
    engine.register_fn("*", |a: ScalarF, b: VectorF| {
        VectorF(fa::scalar_times_vector(a.field, b.0))
    });
    engine.register_fn("*", |a: VectorF, b: ScalarF| {
        VectorF(fa::scalar_times_vector(b.field, a.0))
    });
    engine.register_fn("/", |a: VectorF, s: ScalarF| {
        VectorF(fa::scalar_times_vector(
            fa::div(ops::constant(1.0), s.field),
            a.0,
        ))
    });
    engine.register_fn("*", |a: VectorF, m: MatrixF| {
        VectorF(Arc::new(RowTimes(a.0, m.0)))
    });
    engine.register_fn("*", |k: V3, s: ScalarF| {
        VectorF(fa::scalar_times_vector(s.field, ops::constant_vector(k.0)))
    });

    // vector constants
    engine.register_fn("+", |a: V3, b: V3| V3(a.0 + b.0));
    engine.register_fn("-", |a: V3, b: V3| V3(a.0 - b.0));
    engine.register_fn("-", |a: V3| V3(-a.0));
    engine.register_fn("*", |a: V3, b: V3| (a.0.dot(b.0)) as FLOAT);
    engine.register_fn("to_string", |a: V3| {
        format!("vector({}, {}, {})", a.0.x, a.0.y, a.0.z)
    });

    // caches
    engine.register_fn("+", |a: ScalarCache, b: ScalarCache| {
        zip_caches(a, &b, |x, y| x + y)
    });
    engine.register_fn("-", |a: ScalarCache, b: ScalarCache| {
        zip_caches(a, &b, |x, y| x - y)
    });
    engine.register_fn("*", |a: ScalarCache, b: ScalarCache| {
        zip_caches(a, &b, |x, y| x * y)
    });
    engine.register_fn("-", |a: ScalarCache| map_cache(a, |x| -x));
    engine.register_fn("+", |a: ScalarCache, s: ScalarF| cache_plus_field(a, &s));
    engine.register_fn("*", |k: V3, c: ScalarCache| force_on_faces(k.0, &c.grid));
    engine.register_fn("+", |a: VectorCache, b: VectorCache| {
        zip_faces(a, &b.0, |x, y| x + y)
    });
    engine.register_fn("-", |a: VectorCache, b: VectorCache| {
        zip_faces(a, &b.0, |x, y| x - y)
    });
    engine.register_fn("+", |a: VectorCache, v: VectorF| {
        let b = FaceGrid::from_field(*a.0.domain(), a.0.kind(), &*v.0);
        zip_faces(a, &b, |x, y| x + y)
    });
    engine.register_fn("-", |a: VectorCache, v: VectorF| {
        let b = FaceGrid::from_field(*a.0.domain(), a.0.kind(), &*v.0);
        zip_faces(a, &b, |x, y| x - y)
    });
    engine.register_fn("*", |a: VectorCache, v: VectorF| {
        let u: Vector = a.0;
        ScalarF::new(fa::dot(u, v.0))
    });

    macro_rules! numbers {
        ($($t:ty),*) => {$(
            engine.register_fn("+", move |a: ScalarF, b: $t| sf(fa::add(a.field, num(b as f32))));
            engine.register_fn("+", move |b: $t, a: ScalarF| sf(fa::add(num(b as f32), a.field)));
            engine.register_fn("-", move |a: ScalarF, b: $t| sf(fa::sub(a.field, num(b as f32))));
            engine.register_fn("-", move |b: $t, a: ScalarF| sf(fa::sub(num(b as f32), a.field)));
            engine.register_fn("*", move |a: ScalarF, b: $t| sf(ops::scale(a.field, b as f32)));
            engine.register_fn("*", move |b: $t, a: ScalarF| sf(ops::scale(a.field, b as f32)));
            engine.register_fn("/", move |a: ScalarF, b: $t| sf(ops::scale(a.field, 1.0 / b as f32)));
            engine.register_fn("/", move |b: $t, a: ScalarF| sf(fa::div(num(b as f32), a.field)));
            engine.register_fn("^", move |a: ScalarF, e: $t| sf(fa::pow(a.field, e as f32)));
            engine.register_fn("**", move |a: ScalarF, e: $t| sf(fa::pow(a.field, e as f32)));
            engine.register_fn("*", |a: VectorF, b: $t| VectorF(ops::vector_scale(a.0, b as f32)));
            engine.register_fn("*", |b: $t, a: VectorF| VectorF(ops::vector_scale(a.0, b as f32)));
            engine.register_fn("/", |a: VectorF, b: $t| VectorF(ops::vector_scale(a.0, 1.0 / b as f32)));
            engine.register_fn("*", |a: V3, b: $t| V3(a.0 * b as f32));
            engine.register_fn("*", |b: $t, a: V3| V3(a.0 * b as f32));
            engine.register_fn("/", |a: V3, b: $t| V3(a.0 / b as f32));
            engine.register_fn("*", |a: ScalarCache, b: $t| map_cache(a, |x| x * b as f32));
            engine.register_fn("*", |b: $t, a: ScalarCache| map_cache(a, |x| b as f32 * x));
            engine.register_fn("*", |a: VectorCache, b: $t| scale_faces(a, b as f32));
            engine.register_fn("*", |b: $t, a: VectorCache| scale_faces(a, b as f32));
            engine.register_fn("/", |a: VectorCache, b: $t| scale_faces(a, 1.0 / b as f32));
        )*};
    }
    numbers!(FLOAT, INT);
}
