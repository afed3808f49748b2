//! The notes' functions, each a thin call into the library.
//!
//! | script | library |
//! |---|---|
//! | `domain(res, size)`, `domain(res, size, "closed")` | [`Domain::cube`], the box `[0, size]³`, periodic or closed ([`BoxKind`]) |
//! | `vector(x, y, z)`, `scalarfield(c)`, `vectorfield(v)` | constants ([`ops::constant`], [`ops::constant_vector`]) |
//! | `identity()` | [`ops::identity`] |
//! | `mask(f)` | [`ops::mask`] |
//! | `inject(center, dt)` / `inject(center, radius, dt)` | [`ops::inject`]: `mask(r² − |x − c|²)·Δt` |
//! | `compose(f, X)` | [`fa::compose`], [`fa::compose_vector`], [`fa::compose_matrix`] |
//! | `grad(f)`, `grad(f, h)`, `hessian(f, h)` | [`fa::grad`], [`fa::hessian`]; `grad` of a vectorfield is [`fa::jacobian`], so `grad(grad(ℓ))` is the Hessian (eq 4.4) |
//! | `levelsetsurface(ℓ, n)` | [`fa::levelset_surface`] (eq 3.3) |
//! | `abs`, `sqrt`, `clamp`, `min`, `max`, `normalize` | [`fa`]'s pointwise operations (`min`/`max` of two fields or a field and a number) |
//! | `sin`, `cos`, `exp`, `tanh` of a scalarfield (or a number) | [`fa::sin`], [`fa::cos`], [`fa::exp`], [`fa::tanh`] |
//! | `v.x`, `v.y`, `v.z`, `component(v, axis)` of a vectorfield or vectorcache | [`fa::component`] (a cache's trilinear point query) |
//! | `advect(f, u, dt)` — fields | [`ops::advect`], [`ops::advect_vector`] (Euler backtrace) |
//! | `advect(f, velocity, dt)` — `velocity` a cache | `f ∘` the library's departure map ([`departure_point`]), the gridless density of §6.2 |
//! | `advect(cache, velocity, dt)` | [`Departures::trace`] + [`interpolate_scalar`]: the semi-Lagrangian sweep of `Simulation::advect`, departures shared by the caches of one step |
//! | `advect(velocity, velocity, dt)` | [`advect_faces`]: the velocity's own step in `Simulation::advect` |
//! | `advection(region, "quick")` | later `advect`s of caches by [`Quick`] (`prepare` once per velocity and Δt, `advect_scalar` with the ULTIMATE limiter, `advect_faces`): `Advector::advect`'s QUICK step, `run --advection quick`; `"maccormack"`, `"bfecc"`: by [`corrected_scalar`] / [`corrected_faces`], `run --advection maccormack\|bfecc`; `"sl"` returns to the notes' semi-Lagrangian `advect` |
//! | `fftdivfree(velocity, region)` | [`PressureSolver::project`], `Simulation::project` (eq 6.3; cosine transforms in a closed box) |
//! | `diffuse(velocity, region, nu, dt)` | [`PressureSolver::diffuse`]: the exact viscous step `Simulation::project` takes before the projection (`run --nu`) |
//! | `scalarcache(region, name)`, `vectorcache(region)` | empty grids ([`ScalarGrid::zeros`], [`FaceGrid::zeros`]) |
//! | `cachewrite(cache, f)`, `cacheread(cache)` | [`ScalarGrid::from_field`] / [`FaceGrid::from_field`], and the grid as a field (trilinear) |
//! | `cacheaverage(cache, f)` | [`cell_averages`] over 2×2×2 sub-cells: SELMA's re-anchoring resample (`density::selma`) |
//! | `mapcache(region)`, `advect(map, velocity, dt)`, `cacheread(map)`, `deformation(map)` | SELMA's gridded map (eq 8.8), see [`super::map`] |
//! | `perlin(seed)`, `fractalsum(n, octaves, jump, rough)` | [`Perlin`], [`cloud::fractal_sum`] (eq 3.6) |
//! | `noiselayers(count, noise, scale, freq, fjump, rough)` | [`cloud::noise_layers`] (§3.6) |
//! | `cumulo(base, layers, h, iterations)` | [`cloud::cumulo`] (eq 3.5), uncached |
//! | `sphere(c, r)` | [`ops::sphere`], the implicit `r² − |x − c|²` |
//! | `spheredistance(c, r)`, `plane(p, n)`, `ellipsoid(c, radii)`, `torus(c, axis, R, r)` | [`shape`]'s level sets |
//! | `cutinside(ℓ, knife)`, `cutoutside(ℓ, knife)` | [`cut::cut_inside`], [`cut::cut_outside`] (§5.2) |
//! | `nacelle(reference, object, h, iterations)` | [`warp::Nacelle::iterate`] (eqs 4.7–4.10), the last map |

use std::cell::RefCell;
use std::sync::{Arc, Weak};

use glam::Vec3;
use rhai::{Array, Engine, FLOAT, INT};
use smokelab::advection::{
    advect_faces, corrected_faces, corrected_scalar, departure_point, interpolate_scalar,
    Backtrace, Correction, Departures, Limiter, Quick, QuickOptions, Scheme,
};
use smokelab::density::probe::cell_averages;
use smokelab::domain::Domain;
use smokelab::field::algebra as fa;
use smokelab::field::{ops, Scalar, Vector, VectorField};
use smokelab::grid::{BoxKind, FaceGrid, ScalarGrid};
use smokelab::model::{cloud, cut, shape, warp};
use smokelab::noise::perlin::Perlin;
use smokelab::pressure::PressurePrecision;

use super::output::{output_name, Named};
use super::types::{
    time_step, Fallible, MatrixF, Region, ScalarCache, ScalarF, VectorCache, VectorF, V3,
};

/// `x ↦` the departure point of `x` through a velocity cache over `Δt`: the
/// same arithmetic as the library's gridless and SELMA densities
/// ([`departure_point`]), in world coordinates.
struct Departure {
    velocity: Arc<FaceGrid>,
    dt_cells: f32,
    backtrace: Backtrace,
}

impl VectorField for Departure {
    fn eval(&self, p: Vec3) -> Vec3 {
        let d = self.velocity.domain();
        let g = departure_point(
            &self.velocity,
            d.grid_coords(p),
            self.dt_cells,
            self.backtrace,
        );
        d.world_of(g)
    }
}

fn departure(velocity: &VectorCache, dt: f32) -> Vector {
    Arc::new(Departure {
        dt_cells: dt / velocity.0.domain().cell,
        velocity: velocity.0.clone(),
        backtrace: Backtrace::default(),
    })
}

/// The last departure points of the cell centres: the velocity they were
/// traced through (weakly: a changed or dropped grid does not match) and Δt.
type Traced = Option<(Weak<FaceGrid>, f32, Departures)>;

thread_local! {
    /// The densities of one step share their departure points, as in
    /// `Simulation::advect`'s fused sweep.
    static TRACED: RefCell<Traced> = const { RefCell::new(None) };
}

/// `f(departures)`: the departure points of the cell centres through `u`
/// over `dt` ([`Departures::trace`], the library's sweep), traced only when
/// `u` or `dt` changed since the last call.
pub fn with_departures<T>(u: &Arc<FaceGrid>, dt: f32, f: impl FnOnce(&Departures) -> T) -> T {
    TRACED.with(|t| {
        let mut t = t.borrow_mut();
        let hit = matches!(&*t, Some((w, d, _)) if *d == dt
            && w.upgrade().is_some_and(|v| Arc::ptr_eq(&v, u)));
        if !hit {
            let mut dep = Departures::new(*u.domain());
            dep.trace(u, dt, Backtrace::default());
            *t = Some((Arc::downgrade(u), dt, dep));
        }
        let (_, _, dep) = t.as_ref().expect("traced above");
        f(dep)
    })
}

/// `ρ(x_d)`: the cache interpolated at the shared departure points
/// ([`with_departures`]) by [`interpolate_scalar`], the arithmetic of the
/// library's sweep.
fn advect_cache(c: &ScalarGrid, u: &Arc<FaceGrid>, dt: f32) -> ScalarGrid {
    with_departures(u, dt, |dep| {
        let mut out = ScalarGrid::zeros(*c.domain()).with_wrap(c.wrap());
        interpolate_scalar(c, dep, &mut out);
        out
    })
}

/// The script's QUICK advector, once `advection(region, "quick")` chose it,
/// and the velocity and Δt its step is prepared for (weakly, as [`TRACED`]).
struct QuickState {
    domain: Domain,
    quick: Quick,
    prepared: Option<(Weak<FaceGrid>, f32)>,
}

/// How the script's caches advect: the scheme `advection(region, …)` chose.
enum ScriptScheme {
    /// The notes' semi-Lagrangian `advect` (the default).
    SemiLagrangian,
    /// QUICK finite volumes (boxed: its scratch is large).
    Quick(Box<QuickState>),
    /// MacCormack or BFECC on the semi-Lagrangian steps.
    Corrected(Correction),
}

thread_local! {
    static SCHEME: RefCell<ScriptScheme> = const { RefCell::new(ScriptScheme::SemiLagrangian) };
}

/// `f(quick)` with QUICK prepared for `u` over `dt` (`Quick::prepare`, once
/// per velocity and Δt, as `Advector::advect` does once per step); `None`
/// when the script does not advect by QUICK.
fn with_quick<T>(
    u: &Arc<FaceGrid>,
    dt: f32,
    f: impl FnOnce(&mut Quick) -> T,
) -> Option<Fallible<T>> {
    SCHEME.with(|s| {
        let mut s = s.borrow_mut();
        let ScriptScheme::Quick(state) = &mut *s else {
            return None;
        };
        if &state.domain != u.domain() {
            return Some(Err("advect: the velocity is not on the QUICK region".into()));
        }
        let ready = matches!(&state.prepared, Some((w, d)) if *d == dt
            && w.upgrade().is_some_and(|v| Arc::ptr_eq(&v, u)));
        if !ready {
            state.prepared = None;
            if let Err(e) = state.quick.prepare(u, dt) {
                return Some(Err(format!("advect: {e}").into()));
            }
            state.prepared = Some((Arc::downgrade(u), dt));
        }
        Some(Ok(f(&mut state.quick)))
    })
}

/// The correction of MacCormack or BFECC, when the script advects by one.
fn correction() -> Option<Correction> {
    SCHEME.with(|s| match &*s.borrow() {
        ScriptScheme::Corrected(c) => Some(*c),
        _ => None,
    })
}

/// `advection(region, scheme)`: one of `run --advection`'s schemes for
/// every later `advect` of a cache — `"sl"` (the notes' semi-Lagrangian
/// `advect`), `"quick"` (QUICK finite volumes with its defaults: CFL
/// sub-steps, the ULTIMATE limiter on densities; periodic boxes),
/// `"maccormack"` or `"bfecc"` (the corrected semi-Lagrangian steps).
fn set_advection(region: Region, scheme: &str) -> Fallible<()> {
    let names = Scheme::ALL.map(Scheme::name).join("\", \"");
    let Some(parsed) = Scheme::ALL.into_iter().find(|s| s.name() == scheme) else {
        return Err(format!("advection: `{scheme}`; expected one of \"{names}\"").into());
    };
    let state = match parsed {
        Scheme::Sl => ScriptScheme::SemiLagrangian,
        Scheme::Quick if region.kind == BoxKind::Periodic => {
            ScriptScheme::Quick(Box::new(QuickState {
                domain: region.domain,
                quick: Quick::new(region.domain, QuickOptions::default()),
                prepared: None,
            }))
        }
        Scheme::Quick => {
            return Err("advection: QUICK is periodic; the region is a closed box".into())
        }
        Scheme::MacCormack => ScriptScheme::Corrected(Correction::MacCormack),
        Scheme::Bfecc => ScriptScheme::Corrected(Correction::Bfecc),
    };
    SCHEME.with(|s| *s.borrow_mut() = state);
    Ok(())
}

/// The scalar fields of a script array, or an error naming the wrong element.
fn scalars(a: &Array, what: &str) -> Fallible<Vec<Scalar>> {
    a.iter()
        .enumerate()
        .map(|(i, d)| {
            d.clone()
                .try_cast::<ScalarF>()
                .map(|s| s.field)
                .ok_or_else(|| {
                    format!(
                        "{what}: element {i} is a {}, expected a scalarfield",
                        d.type_name()
                    )
                    .into()
                })
        })
        .collect()
}

fn positive(what: &str, x: f32) -> Fallible<f32> {
    if x > 0.0 && x.is_finite() {
        Ok(x)
    } else {
        Err(format!("{what} is {x}; it must be positive").into())
    }
}

fn count(what: &str, n: INT) -> Fallible<usize> {
    usize::try_from(n).map_err(|_| format!("{what} is {n}; it must be at least 0").into())
}

/// `domain(res, size, box)`: the cube `[0, size]³` of `res`³ cells, its
/// faces `"periodic"` or `"closed"` (`smokelab run --box`), its pressure
/// solved in `precision` (`smokelab script --pressure-precision`).
fn region(res: INT, size: FLOAT, kind: &str, precision: PressurePrecision) -> Fallible<Region> {
    let res = usize::try_from(res).map_err(|_| format!("domain: res is {res}"))?;
    let d = Domain::cube(res, size as f32).map_err(|e| e.to_string())?;
    let kind = match kind {
        "periodic" => BoxKind::Periodic,
        "closed" => BoxKind::Closed,
        other => {
            return Err(
                format!("domain: box `{other}`; expected \"periodic\" or \"closed\"").into(),
            )
        }
    };
    Ok(Region::new(d, kind, precision))
}

/// Refuse a velocity that is not on `region`'s grid and box.
fn on_region(what: &str, v: &VectorCache, region: &Region) -> Fallible<()> {
    if v.0.domain() != &region.domain || v.0.kind() != region.kind {
        return Err(format!("{what}: the velocity is not on this region").into());
    }
    Ok(())
}

/// Register the notes' functions; every `domain` solves its pressure in
/// `precision`.
pub fn register(engine: &mut Engine, precision: PressurePrecision) {
    let sf = ScalarF::new;
    engine.register_fn("domain", move |res: INT, size: FLOAT| {
        region(res, size, "periodic", precision)
    });
    engine.register_fn("domain", move |res: INT, size: FLOAT, kind: &str| {
        region(res, size, kind, precision)
    });
    engine.register_fn("vector", |x: FLOAT, y: FLOAT, z: FLOAT| {
        V3(Vec3::new(x as f32, y as f32, z as f32))
    });
    engine.register_fn("scalarfield", move |c: FLOAT| sf(ops::constant(c as f32)));
    engine.register_fn("scalarfield", move |c: INT| sf(ops::constant(c as f32)));
    engine.register_fn("vectorfield", |v: V3| VectorF(ops::constant_vector(v.0)));
    engine.register_fn("identity", || VectorF(ops::identity()));
    engine.register_fn("mask", move |f: ScalarF| sf(ops::mask(f.field)));
    engine.register_fn("inject", move |c: V3, dt: FLOAT| -> Fallible<ScalarF> {
        Ok(sf(ops::inject(c.0, 1.0, time_step("inject", dt)?)))
    });
    engine.register_fn(
        "inject",
        move |c: V3, r: FLOAT, dt: FLOAT| -> Fallible<ScalarF> {
            Ok(sf(ops::inject(c.0, r as f32, time_step("inject", dt)?)))
        },
    );
    engine.register_fn("compose", move |f: ScalarF, x: VectorF| {
        sf(fa::compose(f.field, x.0))
    });
    engine.register_fn("compose", |v: VectorF, x: VectorF| {
        VectorF(fa::compose_vector(v.0, x.0))
    });
    engine.register_fn("compose", |m: MatrixF, x: VectorF| {
        MatrixF(fa::compose_matrix(m.0, x.0))
    });
    engine.register_fn("grad", |f: ScalarF| VectorF(fa::grad(f.field, 1e-3)));
    engine.register_fn("grad", |f: ScalarF, h: FLOAT| -> Fallible<VectorF> {
        Ok(VectorF(fa::grad(f.field, positive("grad: h", h as f32)?)))
    });
    engine.register_fn("grad", |v: VectorF| MatrixF(fa::jacobian(v.0, 1e-3)));
    engine.register_fn("grad", |v: VectorF, h: FLOAT| -> Fallible<MatrixF> {
        Ok(MatrixF(fa::jacobian(v.0, positive("grad: h", h as f32)?)))
    });
    engine.register_fn("hessian", |f: ScalarF, h: FLOAT| -> Fallible<MatrixF> {
        Ok(MatrixF(fa::hessian(
            f.field,
            positive("hessian: h", h as f32)?,
        )))
    });
    engine.register_fn(
        "levelsetsurface",
        |l: ScalarF, n: INT| -> Fallible<VectorF> {
            Ok(VectorF(fa::levelset_surface(
                l.field,
                1e-3,
                count("levelsetsurface: iterations", n)?,
            )))
        },
    );
    engine.register_fn("abs", move |f: ScalarF| sf(fa::abs(f.field)));
    engine.register_fn("sqrt", move |f: ScalarF| sf(fa::sqrt(f.field)));
    engine.register_fn("clamp", move |f: ScalarF, lo: FLOAT, hi: FLOAT| {
        sf(fa::clamp(f.field, lo as f32, hi as f32))
    });
    engine.register_fn("min", move |a: ScalarF, b: ScalarF| {
        sf(fa::min(a.field, b.field))
    });
    engine.register_fn("max", move |a: ScalarF, b: ScalarF| {
        sf(fa::max(a.field, b.field))
    });
    engine.register_fn("normalize", |v: VectorF| VectorF(fa::normalize(v.0)));
    engine.register_fn("sin", move |f: ScalarF| sf(fa::sin(f.field)));
    engine.register_fn("cos", move |f: ScalarF| sf(fa::cos(f.field)));
    engine.register_fn("exp", move |f: ScalarF| sf(fa::exp(f.field)));
    engine.register_fn("tanh", move |f: ScalarF| sf(fa::tanh(f.field)));
    // Rhai's own `sin` … take a float; an integer argument is one too.
    engine.register_fn("sin", |x: INT| (x as FLOAT).sin());
    engine.register_fn("cos", |x: INT| (x as FLOAT).cos());
    engine.register_fn("exp", |x: INT| (x as FLOAT).exp());
    engine.register_fn("tanh", |x: INT| (x as FLOAT).tanh());
    macro_rules! min_max_number {
        ($($t:ty),*) => {$(
            engine.register_fn("min", move |a: ScalarF, b: $t| sf(fa::min(a.field, ops::constant(b as f32))));
            engine.register_fn("min", move |b: $t, a: ScalarF| sf(fa::min(ops::constant(b as f32), a.field)));
            engine.register_fn("max", move |a: ScalarF, b: $t| sf(fa::max(a.field, ops::constant(b as f32))));
            engine.register_fn("max", move |b: $t, a: ScalarF| sf(fa::max(ops::constant(b as f32), a.field)));
        )*};
    }
    min_max_number!(FLOAT, INT);
    // Components of a vector field, a velocity cache's point query, a constant.
    for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
        engine.register_get(name, move |v: &mut VectorF| {
            sf(fa::component(v.0.clone(), axis))
        });
        engine.register_get(name, move |v: &mut VectorCache| {
            let u: Vector = v.0.clone();
            sf(fa::component(u, axis))
        });
        engine.register_get(name, move |v: &mut V3| v.0[axis] as FLOAT);
    }
    let axis_of = |axis: INT| -> Fallible<usize> {
        match axis {
            0..=2 => Ok(axis as usize),
            _ => Err(format!("component: axis {axis}; expected 0, 1 or 2 (x, y, z)").into()),
        }
    };
    engine.register_fn(
        "component",
        move |v: VectorF, axis: INT| -> Fallible<ScalarF> {
            Ok(sf(fa::component(v.0, axis_of(axis)?)))
        },
    );
    engine.register_fn(
        "component",
        move |v: VectorCache, axis: INT| -> Fallible<ScalarF> {
            let u: Vector = v.0;
            Ok(sf(fa::component(u, axis_of(axis)?)))
        },
    );

    // advect, by the kinds of its arguments.
    engine.register_fn(
        "advect",
        move |f: ScalarF, u: VectorF, dt: FLOAT| -> Fallible<ScalarF> {
            Ok(sf(ops::advect(f.field, u.0, time_step("advect", dt)?)))
        },
    );
    engine.register_fn(
        "advect",
        |v: VectorF, u: VectorF, dt: FLOAT| -> Fallible<VectorF> {
            Ok(VectorF(ops::advect_vector(
                v.0,
                u.0,
                time_step("advect", dt)?,
            )))
        },
    );
    engine.register_fn(
        "advect",
        move |f: ScalarF, u: VectorCache, dt: FLOAT| -> Fallible<ScalarF> {
            let dt = time_step("advect", dt)?;
            Ok(sf(fa::compose(f.field, departure(&u, dt))))
        },
    );
    engine.register_fn(
        "advect",
        |c: ScalarCache, u: VectorCache, dt: FLOAT| -> Fallible<ScalarCache> {
            let dt = time_step("advect", dt)?;
            if c.grid.domain() != u.0.domain() {
                return Err(format!(
                    "advect: `{}` and the velocity are on different domains",
                    c.name
                )
                .into());
            }
            let mut out = ScalarGrid::zeros(*c.grid.domain()).with_wrap(c.grid.wrap());
            let grid = match with_quick(&u.0, dt, |q| {
                q.advect_scalar(&c.grid, &mut out, Limiter::Ultimate)
            }) {
                Some(done) => done.map(|()| out)?,
                None => match correction() {
                    Some(k) => {
                        corrected_scalar(k, &c.grid, &u.0, dt, Backtrace::default(), &mut out);
                        out
                    }
                    None => advect_cache(&c.grid, &u.0, dt),
                },
            };
            Ok(ScalarCache {
                grid: Arc::new(grid),
                name: c.name,
            })
        },
    );
    engine.register_fn(
        "advect",
        |v: VectorCache, u: VectorCache, dt: FLOAT| -> Fallible<VectorCache> {
            let dt = time_step("advect", dt)?;
            if v.0.domain() != u.0.domain() || v.0.kind() != u.0.kind() {
                return Err("advect: the two velocities are on different grids".into());
            }
            let mut out = FaceGrid::zeros(*u.0.domain(), u.0.kind());
            if let Some(done) = with_quick(&u.0, dt, |q| q.advect_faces(&v.0, &mut out)) {
                done?;
            } else if let Some(k) = correction() {
                corrected_faces(k, &v.0, &u.0, dt, Backtrace::default(), &mut out);
            } else {
                advect_faces(&v.0, &u.0, dt, Backtrace::default(), &mut out);
            }
            Ok(VectorCache(Arc::new(out)))
        },
    );
    engine.register_fn("advection", set_advection);
    engine.register_fn(
        "fftdivfree",
        |v: VectorCache, region: Region| -> Fallible<VectorCache> {
            on_region("fftdivfree", &v, &region)?;
            let mut out = (*v.0).clone();
            region.solver.borrow_mut().project(&mut out);
            Ok(VectorCache(Arc::new(out)))
        },
    );
    engine.register_fn(
        "diffuse",
        |v: VectorCache, region: Region, nu: FLOAT, dt: FLOAT| -> Fallible<VectorCache> {
            on_region("diffuse", &v, &region)?;
            let dt = time_step("diffuse", dt)?;
            let mut out = (*v.0).clone();
            region
                .solver
                .borrow_mut()
                .diffuse(&mut out, nu as f32, dt)
                .map_err(|e| format!("diffuse: {e}"))?;
            Ok(VectorCache(Arc::new(out)))
        },
    );

    // caches
    engine.register_fn(
        "scalarcache",
        |r: Region, name: &str| -> Fallible<ScalarCache> {
            Ok(ScalarCache {
                name: output_name("scalarcache", name, Named::Gas)?,
                grid: Arc::new(ScalarGrid::zeros(r.domain).with_wrap(r.kind.wrap())),
            })
        },
    );
    engine.register_fn("vectorcache", |r: Region| {
        VectorCache(Arc::new(FaceGrid::zeros(r.domain, r.kind)))
    });
    engine.register_fn("cachewrite", |c: &mut ScalarCache, f: ScalarF| {
        let g = ScalarGrid::from_field(*c.grid.domain(), &*f.field);
        c.grid = Arc::new(g.with_wrap(c.grid.wrap()));
    });
    engine.register_fn("cachewrite", |c: &mut VectorCache, v: VectorF| {
        c.0 = Arc::new(FaceGrid::from_field(*c.0.domain(), c.0.kind(), &*v.0));
    });
    engine.register_fn("cacheaverage", |c: &mut ScalarCache, f: ScalarF| {
        let g = cell_averages(&*f.field, c.grid.domain(), 2);
        c.grid = Arc::new(g.with_wrap(c.grid.wrap()));
    });
    engine.register_fn("cacheread", move |c: ScalarCache| {
        let f: Scalar = c.grid;
        sf(f)
    });
    engine.register_fn("cacheread", |c: VectorCache| {
        let v: Vector = c.0;
        VectorF(v)
    });

    // modelling: noises, shapes, clouds, cuts, the nacelle
    engine.register_fn("perlin", move |seed: INT| {
        sf(Arc::new(Perlin::new(seed as u64)))
    });
    engine.register_fn(
        "fractalsum",
        move |n: ScalarF, octaves: INT, jump: FLOAT, rough: FLOAT| -> Fallible<ScalarF> {
            let o = count("fractalsum: octaves", octaves)?;
            Ok(sf(cloud::fractal_sum(
                n.field,
                o,
                jump as f32,
                rough as f32,
            )))
        },
    );
    engine.register_fn(
        "noiselayers",
        |n: INT,
         noise: ScalarF,
         scale: ScalarF,
         freq: ScalarF,
         fjump: ScalarF,
         rough: ScalarF|
         -> Fallible<Array> {
            let n = count("noiselayers: count", n)?;
            Ok(cloud::noise_layers(
                n,
                noise.field,
                scale.field,
                freq.field,
                fjump.field,
                rough.field,
            )
            .into_iter()
            .map(|l| rhai::Dynamic::from(ScalarF::new(l)))
            .collect())
        },
    );
    engine.register_fn(
        "cumulo",
        move |base: ScalarF, layers: Array, h: FLOAT, iterations: INT| -> Fallible<ScalarF> {
            let layers = scalars(&layers, "cumulo")?;
            let it = count("cumulo: iterations", iterations)?;
            let h = positive("cumulo: h", h as f32)?;
            let f = cloud::cumulo(base.field, &layers, h, it, &[]).map_err(|e| e.to_string())?;
            Ok(sf(f))
        },
    );
    engine.register_fn("sphere", move |c: V3, r: FLOAT| {
        sf(ops::sphere(c.0, r as f32))
    });
    engine.register_fn("ellipsoid", move |c: V3, radii: V3| -> Fallible<ScalarF> {
        Ok(sf(
            shape::ellipsoid(c.0, radii.0).map_err(|e| e.to_string())?
        ))
    });
    engine.register_fn(
        "torus",
        move |c: V3, axis: V3, major: FLOAT, minor: FLOAT| -> Fallible<ScalarF> {
            let t = shape::torus(c.0, axis.0, major as f32, minor as f32);
            Ok(sf(t.map_err(|e| e.to_string())?))
        },
    );
    engine.register_fn("spheredistance", move |c: V3, r: FLOAT| {
        sf(shape::sphere(c.0, r as f32))
    });
    engine.register_fn("plane", move |p: V3, n: V3| -> Fallible<ScalarF> {
        Ok(sf(shape::plane(p.0, n.0).map_err(|e| e.to_string())?))
    });
    engine.register_fn("cutinside", move |l: ScalarF, k: ScalarF| {
        sf(cut::cut_inside(l.field, k.field))
    });
    engine.register_fn("cutoutside", move |l: ScalarF, k: ScalarF| {
        sf(cut::cut_outside(l.field, k.field))
    });
    engine.register_fn(
        "nacelle",
        |reference: ScalarF, object: ScalarF, h: FLOAT, iterations: INT| -> Fallible<VectorF> {
            let n = count("nacelle: iterations", iterations)?;
            let nacelle = warp::Nacelle {
                reference: reference.field,
                object: object.field,
                h: positive("nacelle: h", h as f32)?,
                cache: None,
            };
            nacelle
                .iterate(n)
                .pop()
                .map(VectorF)
                .ok_or_else(|| "nacelle: iterations must be at least 1".into())
        },
    );
}
