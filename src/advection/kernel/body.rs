//! The kernel, once, for any lane width: `kernel!` expands it in a module
//! that defines the lane types and primitives of one instruction set —
//!
//! - `F`, `I`, `M`: `W` lanes of `f32`, of `i32`, and a lane mask;
//!   `PAIRS`: whether the grid sweeps take two groups at a time;
//! - `splat`, `iota` (`0, 1, …, W − 1`), `add`, `sub`, `mul`, `div`,
//!   `load`, `store` (the first `W` values of a slice), `lt`, `gt`, `ge`,
//!   `nan`, `sel` (`m ? a : b` per lane) on `F`;
//! - `trunc` (toward zero) and `itof` between `F` and `I`, and `floor`:
//!   `⌊g⌋` as `I` and `g − ⌊g⌋`, where `⌊g⌋` fits an `i32` the scalar
//!   stencil's (the truncation, less one where it rounded up, and the
//!   fraction from its conversion back);
//! - `isplat`, `iadd`, `isub`, `imul`, `ilt`, `igt`, `ieq`, `isel`, `imin`
//!   on `I` (wrapping);
//! - `ule` (unsigned `≤`) on `I`;
//! - `and`, `or`, `none` and `bits` (bit `l` for lane `l`) on `M`;
//! - `Plan`, `plan(len, rows, x, shifts)` and `fetch(data, plan, rows, x)`:
//!   how the corners of a stencil on a lattice of `len` values are fetched
//!   (found once for every grid of that layout), and the values
//!   `data[rows[r] + x[c]]` of its four corner rows fetched so; `shifts`
//!   are the rows' offsets from the first when they are the same in every
//!   lane (no wrap or clamp along y and z). The only instruction-set
//!   specific part —
//!
//! all always inlined. The kernel's functions are always inlined too, into
//! its entry points and per-backtrace workers, which alone carry the
//! attributes `kernel!` is given (`#[target_feature(enable = "avx2")]`):
//! each is compiled whole for its instruction set. Every lane does the
//! scalar reference's operations in its order.

/// Lane-wise primitives of one instruction set, each an always-inlined
/// wrapper of its intrinsics: `fn name(args) -> T = expression;`.
///
/// SAFETY (of every wrapper): an instruction set's module is private to
/// the kernel and calls its primitives only from the kernel's functions,
/// which run only inside its entry points — `#[target_feature]`
/// functions that `dispatch!` calls after checking that the CPU has the
/// instruction set — into which they are inlined. Memory is reached only
/// through bounds-checked slices.
macro_rules! prims {
    ($($(#[$m:meta])* fn $name:ident($($arg:ident: $t:ty),*) $(-> $r:ty)? = $e:expr;)*) => {
        $(
            $(#[$m])*
            #[inline(always)]
            #[allow(unused_unsafe)]
            fn $name($($arg: $t),*) $(-> $r)? {
                // SAFETY: see `prims!`.
                unsafe { $e }
            }
        )*
    };
}

macro_rules! kernel {
    ($(#[$tf:meta])*) => {
        use glam::Vec3;

        use crate::advection::Backtrace;
        use crate::grid::Wrap;
        use super::{
            cell_by_reference, cell_displacement_by_reference, cell_row_velocities,
            face_by_reference, face_row_displacements, face_row_velocities, lanes_in, low_lanes,
            point_by_reference, sample_by_reference, shared_face_by_reference, Scratch, SlabOut,
            Sweep, Vel, EULER, MAX_LANES, RK2, RK3,
        };

        /// The lower and upper lattice index and the fraction between them
        /// along one axis of `n` lattice points, as the scalar stencil's
        /// `axis` finds them (periodic wrap, or clamp to `[0, n − 1]`), and
        /// the lanes left to the scalar reference (a periodic point more
        /// than a period outside, NaN), whose indices are 0.
        #[inline(always)]
        fn axis(g: F, n: usize, wrap: Wrap) -> (I, I, F, M) {
            let ni = n as i32;
            let (f, t, i0, i1, bad) = match wrap {
                Wrap::Periodic => {
                    let (f, _) = floor(g);
                    let below = ilt(f, isplat(0));
                    let above = igt(f, isplat(ni - 1));
                    let i0 = isel(below, iadd(f, isplat(ni)), isel(above, isub(f, isplat(ni)), f));
                    let i1 = iadd(i0, isplat(1));
                    let i1 = isel(ieq(i1, isplat(ni)), isplat(0), i1);
                    let far = or(ilt(f, isplat(-ni)), igt(f, isplat(2 * ni - 1)));
                    (f, g, i0, i1, or(far, nan(g)))
                }
                Wrap::Clamped => {
                    // `g.clamp(0, n − 1)`: −0 and NaN pass through.
                    let (zero, top) = (splat(0.0), splat((n - 1) as f32));
                    let c = sel(lt(g, zero), zero, g);
                    let c = sel(gt(c, top), top, c);
                    let f = trunc(c);
                    let i1 = imin(iadd(f, isplat(1)), isplat(ni - 1));
                    (f, c, f, i1, nan(g))
                }
            };
            let frac = sub(t, itof(f));
            let zero = isplat(0);
            (isel(bad, zero, i0), isel(bad, zero, i1), frac, bad)
        }

        /// A trilinear stencil in the lanes: the linear index of each
        /// corner row's start (`(y0, z0), (y1, z0), (y0, z1), (y1, z1)`),
        /// the x indices, how the corners are fetched, the eight corner
        /// weights in the scalar stencil's order and products, and the
        /// lanes left to the scalar reference.
        #[derive(Clone, Copy)]
        struct Stencil {
            rows: [I; 4],
            x: [I; 2],
            plan: Plan,
            w: [F; 8],
            bad: M,
        }

        /// The stencil of lattice coordinates `g` on a lattice `d`: where
        /// every lane's lies inside the lattice (`0 ≤ ⌊g⌋ ≤ n − 2` along
        /// each axis, the usual case), its floors and fractions as they
        /// are; else each axis wrapped or clamped ([`axis`]). Inside, both
        /// give the same indices and fractions.
        #[inline(always)]
        fn stencil(d: [usize; 3], wrap: Wrap, g: [F; 3]) -> Stencil {
            let len = d[0] * d[1] * d[2];
            let (nx, nxy) = (d[0] as i32, (d[0] * d[1]) as i32);
            let shifts = [0, nx, nxy, nx + nxy];
            let (mx, mxy) = (isplat(nx), isplat(nxy));
            if d.iter().all(|&n| n >= 2) {
                let (fx, tx) = floor(g[0]);
                let (fy, ty) = floor(g[1]);
                let (fz, tz) = floor(g[2]);
                let inside = and(
                    ule(fx, isplat(nx - 2)),
                    and(ule(fy, isplat(d[1] as i32 - 2)), ule(fz, isplat(d[2] as i32 - 2))),
                );
                if bits(inside) == low_lanes(W) {
                    let row = iadd(imul(fz, mxy), imul(fy, mx));
                    let rows = [
                        row,
                        iadd(row, isplat(shifts[1])),
                        iadd(row, isplat(shifts[2])),
                        iadd(row, isplat(shifts[3])),
                    ];
                    let x = [fx, iadd(fx, isplat(1))];
                    let plan = plan(len, rows, x, Some(shifts));
                    return weighted(rows, x, plan, [tx, ty, tz], none());
                }
            }
            // SAFETY: `outside` has the target features of the kernel's
            // functions, whose entry points alone reach here (`prims!`).
            #[allow(unused_unsafe)]
            unsafe {
                outside(d, wrap, g)
            }
        }

        /// [`stencil`] where some lane's lies outside the lattice: each
        /// axis wrapped or clamped ([`axis`]). Out of line, so that the
        /// usual case's code stays compact.
        #[inline(never)]
        $(#[$tf])*
        fn outside(d: [usize; 3], wrap: Wrap, g: [F; 3]) -> Stencil {
            let len = d[0] * d[1] * d[2];
            let (nx, nxy) = (d[0] as i32, (d[0] * d[1]) as i32);
            let shifts = [0, nx, nxy, nx + nxy];
            let (mx, mxy) = (isplat(nx), isplat(nxy));
            let (x0, x1, tx, bx) = axis(g[0], d[0], wrap);
            let (y0, y1, ty, by) = axis(g[1], d[1], wrap);
            let (z0, z1, tz, bz) = axis(g[2], d[2], wrap);
            let (y, z) = ([imul(y0, mx), imul(y1, mx)], [imul(z0, mxy), imul(z1, mxy)]);
            let rows = [iadd(z[0], y[0]), iadd(z[0], y[1]), iadd(z[1], y[0]), iadd(z[1], y[1])];
            // The corner rows one row and one slab on in every lane.
            let one = isplat(1);
            let next = and(ieq(y1, iadd(y0, one)), ieq(z1, iadd(z0, one)));
            let shifts = (bits(next) == low_lanes(W)).then_some(shifts);
            let x = [x0, x1];
            let plan = plan(len, rows, x, shifts);
            weighted(rows, x, plan, [tx, ty, tz], or(bx, or(by, bz)))
        }

        /// A stencil from its corners and the fractions `t` along each
        /// axis: the weights `(1 − t, t)` multiplied per corner as the
        /// scalar stencil does.
        #[inline(always)]
        fn weighted(rows: [I; 4], x: [I; 2], plan: Plan, t: [F; 3], bad: M) -> Stencil {
            let one = splat(1.0);
            let [tx, ty, tz] = t;
            let (wx, wy, wz) = ([sub(one, tx), tx], [sub(one, ty), ty], [sub(one, tz), tz]);
            let wxy = [mul(wx[0], wy[0]), mul(wx[1], wy[0]), mul(wx[0], wy[1]), mul(wx[1], wy[1])];
            Stencil {
                rows,
                x,
                plan,
                w: [
                    mul(wxy[0], wz[0]),
                    mul(wxy[1], wz[0]),
                    mul(wxy[2], wz[0]),
                    mul(wxy[3], wz[0]),
                    mul(wxy[0], wz[1]),
                    mul(wxy[1], wz[1]),
                    mul(wxy[2], wz[1]),
                    mul(wxy[3], wz[1]),
                ],
                bad,
            }
        }

        /// `data` (laid out like the stencil's lattice) through the stencil:
        /// the weighted corners summed in order.
        #[inline(always)]
        fn apply(s: Stencil, data: &[f32]) -> F {
            let v = fetch(data, s.plan, s.rows, s.x);
            let mut acc = splat(0.0);
            for c in 0..8 {
                acc = add(acc, mul(s.w[c], v[c >> 1][c & 1]));
            }
            acc
        }

        /// The centre of the cell holding each lane's coordinate `g`
        /// along one axis (`crate::grid::interpolant::cell_centre`'s
        /// operations in its order: `⌊g + ½⌋` below 2²³ in magnitude,
        /// `g + ½` beyond and for NaN).
        #[inline(always)]
        fn centre(g: F) -> F {
            let s = add(g, splat(0.5));
            let big = splat(crate::grid::interpolant::INTEGER_ABOVE);
            let small = and(lt(s, big), gt(s, sub(splat(0.0), big)));
            let (f, _) = floor(s);
            sel(small, itof(f), s)
        }

        /// The coordinates each component is read at across its own axis
        /// (`FaceSampler::at`): `g` (trilinear), or the centre of the cell
        /// holding it (RT0).
        #[inline(always)]
        fn across(vel: &Vel, g: [F; 3]) -> [F; 3] {
            if vel.rt0 {
                [centre(g[0]), centre(g[1]), centre(g[2])]
            } else {
                g
            }
        }

        /// The velocity at cell-centre grid coordinates `g`: component `b`
        /// on its lattice at `g + ½e_b`, its coordinates across `b` those
        /// of [`across`]; and the lanes left.
        #[inline(always)]
        fn velocity(vel: &Vel, g: [F; 3]) -> ([F; 3], M) {
            // The three components written out (a loop stays a loop).
            let half = splat(0.5);
            let c = across(vel, g);
            let s = stencil(vel.dims[0], vel.wrap, [add(g[0], half), c[1], c[2]]);
            let (u, bad) = (apply(s, vel.data[0]), s.bad);
            let s = stencil(vel.dims[1], vel.wrap, [c[0], add(g[1], half), c[2]]);
            let (v, bad) = (apply(s, vel.data[1]), or(bad, s.bad));
            let s = stencil(vel.dims[2], vel.wrap, [c[0], c[1], add(g[2], half)]);
            ([u, v, apply(s, vel.data[2])], or(bad, s.bad))
        }

        /// `c − s·u` per component.
        #[inline(always)]
        fn back(c: [F; 3], u: [F; 3], s: f32) -> [F; 3] {
            minus3(c, scale(u, s))
        }

        /// `s·u` per component.
        #[inline(always)]
        fn scale(u: [F; 3], s: f32) -> [F; 3] {
            let s = splat(s);
            [mul(s, u[0]), mul(s, u[1]), mul(s, u[2])]
        }

        /// `c − d` per component.
        #[inline(always)]
        fn minus3(c: [F; 3], d: [F; 3]) -> [F; 3] {
            [sub(c[0], d[0]), sub(c[1], d[1]), sub(c[2], d[2])]
        }

        /// The midpoint rule's displacements `Δt u(c − ½Δt u0)` of two
        /// groups of points `c` whose velocities are `u0`
        /// (`semi_lagrangian::rk2_displacement`'s operations), their
        /// interpolations interleaved ([`velocity2`]), and the lanes left.
        #[inline(always)]
        fn displace2(vel: &Vel, c: [[F; 3]; 2], u0: [[F; 3]; 2], dt: f32) -> [([F; 3], M); 2] {
            let mid = [back(c[0], u0[0], 0.5 * dt), back(c[1], u0[1], 0.5 * dt)];
            let [(ua, ba), (ub, bb)] = velocity2(vel, mid);
            [(scale(ua, dt), ba), (scale(ub, dt), bb)]
        }

        /// The departure points of the points `c` whose velocities are
        /// `u0`, traced back through `vel` over `dt` cells with backtrace
        /// `BT` (`semi_lagrangian::departure`'s operations), and the lanes
        /// left.
        #[inline(always)]
        fn trace<const BT: u8>(vel: &Vel, c: [F; 3], u0: [F; 3], dt: f32) -> ([F; 3], M) {
            match BT {
                EULER => (back(c, u0, dt), none()),
                RK2 => {
                    let (u1, bad) = velocity(vel, back(c, u0, 0.5 * dt));
                    (minus3(c, scale(u1, dt)), bad)
                }
                _ => {
                    // Kutta's RK3 for dx/dt = −u(x): k1 = −u(x),
                    // k2 = −u(x + ½k1), k3 = −u(x − k1 + 2k2),
                    // x_d = x + (k1 + 4k2 + k3)/6 (times Δt).
                    let m = splat(-dt);
                    let (half, two, four, six) = (splat(0.5), splat(2.0), splat(4.0), splat(6.0));
                    let k1 = [mul(m, u0[0]), mul(m, u0[1]), mul(m, u0[2])];
                    let p2 = [
                        add(c[0], mul(half, k1[0])),
                        add(c[1], mul(half, k1[1])),
                        add(c[2], mul(half, k1[2])),
                    ];
                    let (v2, b2) = velocity(vel, p2);
                    let k2 = [mul(m, v2[0]), mul(m, v2[1]), mul(m, v2[2])];
                    let mut p3 = c;
                    for a in 0..3 {
                        p3[a] = add(sub(c[a], k1[a]), mul(two, k2[a]));
                    }
                    let (v3, b3) = velocity(vel, p3);
                    let mut g = c;
                    for a in 0..3 {
                        let k3 = mul(m, v3[a]);
                        g[a] = add(c[a], div(add(add(k1[a], mul(four, k2[a])), k3), six));
                    }
                    (g, or(b2, b3))
                }
            }
        }

        /// [`velocity`] at two groups of points, their interpolations
        /// interleaved component by component: the chains of one overlap
        /// the other's (an interpolation waits mostly on its own chain of
        /// latencies, floor → row → window → loads → permutes → sums).
        #[inline(always)]
        fn velocity2(vel: &Vel, g: [[F; 3]; 2]) -> [([F; 3], M); 2] {
            let half = splat(0.5);
            let [a, b] = g;
            let (ca, cb) = (across(vel, a), across(vel, b));
            let (d, w) = (vel.dims, vel.wrap);
            let (sa, sb) = (
                stencil(d[0], w, [add(a[0], half), ca[1], ca[2]]),
                stencil(d[0], w, [add(b[0], half), cb[1], cb[2]]),
            );
            let (ua, ub) = (apply(sa, vel.data[0]), apply(sb, vel.data[0]));
            let (mut bad_a, mut bad_b) = (sa.bad, sb.bad);
            let (sa, sb) = (
                stencil(d[1], w, [ca[0], add(a[1], half), ca[2]]),
                stencil(d[1], w, [cb[0], add(b[1], half), cb[2]]),
            );
            let (va, vb) = (apply(sa, vel.data[1]), apply(sb, vel.data[1]));
            (bad_a, bad_b) = (or(bad_a, sa.bad), or(bad_b, sb.bad));
            let (sa, sb) = (
                stencil(d[2], w, [ca[0], ca[1], add(a[2], half)]),
                stencil(d[2], w, [cb[0], cb[1], add(b[2], half)]),
            );
            let (wa, wb) = (apply(sa, vel.data[2]), apply(sb, vel.data[2]));
            [([ua, va, wa], or(bad_a, sa.bad)), ([ub, vb, wb], or(bad_b, sb.bad))]
        }

        /// [`trace`] of two groups, the RK2 midpoints' interpolations
        /// interleaved ([`velocity2`]).
        #[inline(always)]
        fn trace2<const BT: u8>(vel: &Vel, c: [[F; 3]; 2], u0: [[F; 3]; 2], dt: f32) -> [([F; 3], M); 2] {
            match BT {
                RK2 => {
                    let [(da, ba), (db, bb)] = displace2(vel, c, u0, dt);
                    [(minus3(c[0], da), ba), (minus3(c[1], db), bb)]
                }
                _ => [trace::<BT>(vel, c[0], u0[0], dt), trace::<BT>(vel, c[1], u0[1], dt)],
            }
        }

        /// Grid coordinates of lanes `i …` of row `(j, k)`: cell centres,
        /// or faces of component `a` (−½ along `a`).
        #[inline(always)]
        fn row_points(i: usize, j: usize, k: usize, face: Option<usize>) -> [F; 3] {
            let mut c = [add(splat(i as f32), iota()), splat(j as f32), splat(k as f32)];
            if let Some(a) = face {
                c[a] = sub(c[a], splat(0.5));
            }
            c
        }

        /// `W` lanes of `s` from its start, the lanes past `n` zero.
        #[inline(always)]
        fn load_part(s: &[f32], n: usize) -> F {
            if n >= W {
                load(s)
            } else {
                let mut lanes = [0.0f32; MAX_LANES];
                lanes[..n].copy_from_slice(&s[..n]);
                load(&lanes)
            }
        }

        /// The first `n` lanes of `v` into `out`.
        #[inline(always)]
        fn store_part(out: &mut [f32], v: F, n: usize) {
            if n >= W {
                store(out, v);
            } else {
                let mut lanes = [0.0f32; MAX_LANES];
                store(&mut lanes, v);
                out[..n].copy_from_slice(&lanes[..n]);
            }
        }

        /// The faces of component `A` in slab `k` of its lattice into `out`
        /// (the slab), backtrace `BT`: per row the start velocities
        /// ([`face_row_velocities`]), then `W` faces at a time traced and
        /// interpolated on `A`'s lattice.
        #[inline(never)]
        $(#[$tf])*
        fn faces<const A: usize, const BT: u8>(
            sw: &Sweep,
            data: &[f32],
            k: usize,
            out: &mut [f32],
            scratch: &mut Scratch,
        ) {
            let vel = &sw.vel;
            let d = vel.dims[A];
            for (j, row) in out.chunks_exact_mut(d[0]).enumerate().take(d[1]) {
                face_row_velocities::<A>(vel, (j, k), &mut scratch.u0);
                let u0 = &scratch.u0;
                let mut i = 0;
                while i < d[0] {
                    // Two groups at a time while a second has a lane in the
                    // row, their chains interleaved; the last alone.
                    let two = PAIRS && i + W < d[0];
                    let n = [W.min(d[0] - i), if two { (d[0] - i - W).min(W) } else { 0 }];
                    let c = [row_points(i, j, k, Some(A)), row_points(i + W, j, k, Some(A))];
                    let [(mut ga, bad_a), (mut gb, bad_b)] = match two {
                        true => trace2::<BT>(vel, c, [load3(u0, i), load3(u0, i + W)], sw.dt),
                        false => [trace::<BT>(vel, c[0], load3(u0, i), sw.dt), (c[1], none())],
                    };
                    ga[A] = add(ga[A], splat(0.5));
                    gb[A] = add(gb[A], splat(0.5));
                    let sa = stencil(d, vel.wrap, ga);
                    let mut left = [bits(or(bad_a, sa.bad)), 0];
                    if two {
                        let sb = stencil(d, vel.wrap, gb);
                        let (va, vb) = (apply(sa, data), apply(sb, data));
                        store_part(&mut row[i..], va, n[0]);
                        store_part(&mut row[i + W..], vb, n[1]);
                        left[1] = bits(or(bad_b, sb.bad));
                    } else {
                        store_part(&mut row[i..], apply(sa, data), n[0]);
                    }
                    for (g, (left, n)) in left.into_iter().zip(n).enumerate() {
                        for l in lanes_in(left & low_lanes(n)) {
                            let f = [i + g * W + l, j, k];
                            row[f[0]] = face_by_reference::<A>(vel, (sw.dt, sw.backtrace), data, f);
                        }
                    }
                    i += if two { 2 * W } else { W };
                }
            }
        }

        /// The start velocities of lanes `i …` of a row (`u0`, each row
        /// padded past its end).
        #[inline(always)]
        fn load3(u0: &[Vec<f32>; 3], i: usize) -> [F; 3] {
            [load(&u0[0][i..]), load(&u0[1][i..]), load(&u0[2][i..])]
        }

        /// The gases' cells in slab `k` into `outs` (their slabs),
        /// backtrace `BT`: per row the start velocities
        /// ([`cell_row_velocities`]), then `W` cells at a time traced once
        /// and every gas interpolated through one stencil (one per wrap).
        /// With `disp` (RK2 only), each cell's displacement `d` (the
        /// departure point is `c − d`) into it too: three planes, x, y, z,
        /// of the slab's cells.
        #[inline(never)]
        $(#[$tf])*
        fn cells<const BT: u8>(
            sw: &Sweep,
            k: usize,
            outs: &mut [&mut [f32]],
            mut disp: Option<&mut [f32]>,
            scratch: &mut Scratch,
        ) {
            let vel = &sw.vel;
            let [nx, ny, _] = vel.cells;
            let nxy = nx * ny;
            let first = sw.gases.first().map_or(vel.wrap, |g| g.1);
            for j in 0..ny {
                cell_row_velocities(vel, (j, k), &mut scratch.u0);
                let u0 = &scratch.u0;
                let mut i = 0;
                while i < nx {
                    // Two groups at a time, as in `faces`.
                    let two = PAIRS && i + W < nx;
                    let n = [W.min(nx - i), if two { (nx - i - W).min(W) } else { 0 }];
                    let c = [row_points(i, j, k, None), row_points(i + W, j, k, None)];
                    let u = [load3(u0, i), load3(u0, i + W)];
                    let [(ga, bad_a), (gb, bad_b)] = match disp.as_deref_mut() {
                        Some(disp) => {
                            let [(da, bad_a), (db, bad_b)] = match two {
                                true => displace2(vel, c, u, sw.dt),
                                false => {
                                    let (u1, bad) = velocity(vel, back(c[0], u[0], 0.5 * sw.dt));
                                    [(scale(u1, sw.dt), bad), (c[1], none())]
                                }
                            };
                            for a in 0..3 {
                                let at = a * nxy + j * nx + i;
                                store_part(&mut disp[at..], da[a], n[0]);
                                if two {
                                    store_part(&mut disp[at + W..], db[a], n[1]);
                                }
                            }
                            [(minus3(c[0], da), bad_a), (minus3(c[1], db), bad_b)]
                        }
                        None => match two {
                            true => trace2::<BT>(vel, c, u, sw.dt),
                            false => [trace::<BT>(vel, c[0], u[0], sw.dt), (c[1], none())],
                        },
                    };
                    // One stencil per group for every gas of the first's
                    // wrap (the gases of a box share it).
                    let mut left = [bits(bad_a), bits(bad_b)];
                    let sample = !sw.gases.is_empty();
                    if sample && two {
                        let (sa, sb) = (stencil(vel.cells, first, ga), stencil(vel.cells, first, gb));
                        left = [left[0] | bits(sa.bad), left[1] | bits(sb.bad)];
                        for ((data, wrap), out) in sw.gases.iter().zip(outs.iter_mut()) {
                            let (va, vb) = match *wrap == first {
                                true => (apply(sa, data), apply(sb, data)),
                                false => {
                                    let sa = stencil(vel.cells, *wrap, ga);
                                    let sb = stencil(vel.cells, *wrap, gb);
                                    left = [left[0] | bits(sa.bad), left[1] | bits(sb.bad)];
                                    (apply(sa, data), apply(sb, data))
                                }
                            };
                            store_part(&mut out[j * nx + i..], va, n[0]);
                            store_part(&mut out[j * nx + i + W..], vb, n[1]);
                        }
                    } else if sample {
                        let sa = stencil(vel.cells, first, ga);
                        left[0] |= bits(sa.bad);
                        for ((data, wrap), out) in sw.gases.iter().zip(outs.iter_mut()) {
                            let va = match *wrap == first {
                                true => apply(sa, data),
                                false => {
                                    let sa = stencil(vel.cells, *wrap, ga);
                                    left[0] |= bits(sa.bad);
                                    apply(sa, data)
                                }
                            };
                            store_part(&mut out[j * nx + i..], va, n[0]);
                        }
                    }
                    for (g, (left, n)) in left.into_iter().zip(n).enumerate() {
                        for l in lanes_in(left & low_lanes(n)) {
                            let c = [i + g * W + l, j, k];
                            let p = match disp.as_deref_mut() {
                                Some(disp) => {
                                    let d = cell_displacement_by_reference(vel, sw.dt, c);
                                    for a in 0..3 {
                                        disp[a * nxy + j * nx + c[0]] = d[a];
                                    }
                                    Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) - d
                                }
                                None => cell_by_reference(vel, (sw.dt, sw.backtrace), c),
                            };
                            for ((data, wrap), out) in sw.gases.iter().zip(outs.iter_mut()) {
                                out[j * nx + c[0]] = sample_by_reference(data, (vel.cells, *wrap), p);
                            }
                        }
                    }
                    i += if two { 2 * W } else { W };
                }
            }
        }

        /// The faces of component `A` in slab `k` of its lattice into `out`
        /// (the slab) by the RK2 sweep ([`super::chunk`]): per row the
        /// faces' mean displacements `d̄` ([`face_row_displacements`] of the
        /// cells' in `slabs`, the slabs below and at the faces), then `W`
        /// faces at a time interpolated on `A`'s lattice at `x_f − d̄`.
        #[inline(never)]
        $(#[$tf])*
        fn shared_faces<const A: usize>(
            sw: &Sweep,
            k: usize,
            out: &mut [f32],
            slabs: [&[f32]; 2],
            scratch: &mut Scratch,
        ) {
            let (vel, data) = (&sw.vel, sw.faces[A]);
            let d = vel.dims[A];
            for (j, row) in out.chunks_exact_mut(d[0]).enumerate().take(d[1]) {
                face_row_displacements::<A>(vel, j, slabs, &mut scratch.u0);
                let mean = &scratch.u0;
                let mut i = 0;
                while i < d[0] {
                    // Two groups at a time, as in `faces`.
                    let two = PAIRS && i + W < d[0];
                    let n = [W.min(d[0] - i), if two { (d[0] - i - W).min(W) } else { 0 }];
                    let mut ga = minus3(row_points(i, j, k, Some(A)), load3(mean, i));
                    ga[A] = add(ga[A], splat(0.5));
                    let sa = stencil(d, vel.wrap, ga);
                    let mut left = [bits(sa.bad), 0];
                    if two {
                        let mut gb = minus3(row_points(i + W, j, k, Some(A)), load3(mean, i + W));
                        gb[A] = add(gb[A], splat(0.5));
                        let sb = stencil(d, vel.wrap, gb);
                        let (va, vb) = (apply(sa, data), apply(sb, data));
                        store_part(&mut row[i..], va, n[0]);
                        store_part(&mut row[i + W..], vb, n[1]);
                        left[1] = bits(sb.bad);
                    } else {
                        store_part(&mut row[i..], apply(sa, data), n[0]);
                    }
                    for (g, (left, n)) in left.into_iter().zip(n).enumerate() {
                        for l in lanes_in(left & low_lanes(n)) {
                            let f = i + g * W + l;
                            let m = Vec3::new(mean[0][f], mean[1][f], mean[2][f]);
                            row[f] = shared_face_by_reference::<A>(vel, data, [f, j, k], m);
                        }
                    }
                    i += if two { 2 * W } else { W };
                }
            }
        }

        /// [`super::chunk`] with backtrace RK2: per slab the cells (gases
        /// and displacements), then the faces from the displacements of the
        /// slab and the one below.
        #[inline(never)]
        $(#[$tf])*
        fn shared_chunk(sw: &Sweep, outs: &mut [SlabOut], scratch: &mut Scratch) {
            let Some(k0) = outs.first().map(|o| o.k) else {
                return;
            };
            let nz = sw.vel.cells[2];
            let periodic = sw.vel.wrap == Wrap::Periodic;
            let [mut below, mut at] = std::mem::take(&mut scratch.slabs);
            // The slab below the first: its cells' displacements only.
            if k0 > 0 || periodic {
                let k = if k0 > 0 { k0 - 1 } else { nz - 1 };
                cells::<RK2>(sw, k, &mut [], Some(&mut at), scratch);
            }
            for out in outs {
                let k = out.k;
                std::mem::swap(&mut below, &mut at);
                if k < nz {
                    cells::<RK2>(sw, k, &mut out.gases, Some(&mut at), scratch);
                }
                // A closed box's wall slabs: their one slab of cells.
                let here: &[f32] = if k < nz { &at } else { &below };
                let under: &[f32] = if k > 0 || periodic { &below } else { here };
                let [u, v, w] = &mut out.faces;
                if let Some(u) = u {
                    shared_faces::<0>(sw, k, u, [here, here], scratch);
                }
                if let Some(v) = v {
                    shared_faces::<1>(sw, k, v, [here, here], scratch);
                }
                if let Some(w) = w {
                    shared_faces::<2>(sw, k, w, [under, here], scratch);
                }
            }
            scratch.slabs = [below, at];
        }

        /// One slab of [`super::chunk`] with backtrace `BT` (Euler or RK3).
        #[inline]
        $(#[$tf])*
        fn slab_traced<const BT: u8>(sw: &Sweep, out: &mut SlabOut, scratch: &mut Scratch) {
            let k = out.k;
            let [u, v, w] = &mut out.faces;
            if let Some(u) = u {
                faces::<0, BT>(sw, sw.faces[0], k, u, scratch);
            }
            if let Some(v) = v {
                faces::<1, BT>(sw, sw.faces[1], k, v, scratch);
            }
            if let Some(w) = w {
                faces::<2, BT>(sw, sw.faces[2], k, w, scratch);
            }
            if !sw.gases.is_empty() && k < sw.vel.cells[2] {
                cells::<BT>(sw, k, &mut out.gases, None, scratch);
            }
        }

        /// Consecutive slabs of a sweep (see [`super::chunk`]).
        $(#[$tf])*
        pub(super) fn chunk(sw: &Sweep, outs: &mut [SlabOut], scratch: &mut Scratch) {
            match sw.backtrace {
                Backtrace::Euler => outs.iter_mut().for_each(|o| slab_traced::<EULER>(sw, o, scratch)),
                Backtrace::Rk2 => shared_chunk(sw, outs, scratch),
                Backtrace::Rk3 => outs.iter_mut().for_each(|o| slab_traced::<RK3>(sw, o, scratch)),
                Backtrace::Exact => unreachable!("the exact path takes the reference"),
            }
        }

        /// See [`super::displacements`].
        $(#[$tf])*
        pub(super) fn displacements(sw: &Sweep, k: usize, out: &mut [f32], scratch: &mut Scratch) {
            cells::<RK2>(sw, k, &mut [], Some(out), scratch);
        }

        /// [`super::cell_points`] with backtrace `BT`.
        #[inline(never)]
        $(#[$tf])*
        fn cell_points_traced<const BT: u8>(
            vel: &Vel,
            dt: f32,
            backtrace: Backtrace,
            (j, k): (usize, usize),
            out: [&mut [f32]; 3],
            scratch: &mut Scratch,
        ) {
            let nx = vel.cells[0];
            cell_row_velocities(vel, (j, k), &mut scratch.u0);
            let u0 = &scratch.u0;
            let [ox, oy, oz] = out;
            for i in (0..nx).step_by(W) {
                let n = (nx - i).min(W);
                let c = row_points(i, j, k, None);
                let u = [load(&u0[0][i..]), load(&u0[1][i..]), load(&u0[2][i..])];
                let (g, bad) = trace::<BT>(vel, c, u, dt);
                store_part(&mut ox[i..], g[0], n);
                store_part(&mut oy[i..], g[1], n);
                store_part(&mut oz[i..], g[2], n);
                for l in lanes_in(bits(bad) & low_lanes(n)) {
                    let p = cell_by_reference(vel, (dt, backtrace), [i + l, j, k]);
                    (ox[i + l], oy[i + l], oz[i + l]) = (p.x, p.y, p.z);
                }
            }
        }

        /// See [`super::cell_points`].
        $(#[$tf])*
        pub(super) fn cell_points(
            vel: &Vel,
            dt: f32,
            backtrace: Backtrace,
            j: usize,
            k: usize,
            out: [&mut [f32]; 3],
            scratch: &mut Scratch,
        ) {
            let at = (j, k);
            match backtrace {
                Backtrace::Euler => cell_points_traced::<EULER>(vel, dt, backtrace, at, out, scratch),
                Backtrace::Rk2 => cell_points_traced::<RK2>(vel, dt, backtrace, at, out, scratch),
                Backtrace::Rk3 => cell_points_traced::<RK3>(vel, dt, backtrace, at, out, scratch),
                Backtrace::Exact => unreachable!("the exact path takes the reference"),
            }
        }

        /// See [`super::sample`].
        $(#[$tf])*
        pub(super) fn sample(
            datas: &[&[f32]],
            cells: [usize; 3],
            wrap: Wrap,
            g: [&[f32]; 3],
            outs: &mut [&mut [f32]],
        ) {
            let len = g[0].len();
            for i in (0..len).step_by(W) {
                let n = (len - i).min(W);
                let p = [load_part(&g[0][i..], n), load_part(&g[1][i..], n), load_part(&g[2][i..], n)];
                let s = stencil(cells, wrap, p);
                for (data, out) in datas.iter().zip(outs.iter_mut()) {
                    store_part(&mut out[i..], apply(s, data), n);
                }
                for l in lanes_in(bits(s.bad) & low_lanes(n)) {
                    let p = Vec3::new(g[0][i + l], g[1][i + l], g[2][i + l]);
                    for (data, out) in datas.iter().zip(outs.iter_mut()) {
                        out[i + l] = sample_by_reference(data, (cells, wrap), p);
                    }
                }
            }
        }

        /// `W` points (the first `n` of `g`) as `[x, y, z]` lanes.
        #[inline(always)]
        fn coordinates(g: &[Vec3], n: usize) -> [F; 3] {
            let mut lanes = [[0.0f32; MAX_LANES]; 3];
            for (l, p) in g[..n].iter().enumerate() {
                lanes[0][l] = p.x;
                lanes[1][l] = p.y;
                lanes[2][l] = p.z;
            }
            [load(&lanes[0]), load(&lanes[1]), load(&lanes[2])]
        }

        /// The first `n` points of `[x, y, z]` lanes into `out`, except
        /// those of the lane mask `skip`.
        #[inline(always)]
        fn set_points(out: &mut [Vec3], p: [F; 3], n: usize, skip: u32) {
            let mut lanes = [[0.0f32; MAX_LANES]; 3];
            for (l, v) in lanes.iter_mut().zip(p) {
                store(l, v);
            }
            for (l, o) in out[..n].iter_mut().enumerate() {
                if skip & (1 << l) == 0 {
                    *o = Vec3::new(lanes[0][l], lanes[1][l], lanes[2][l]);
                }
            }
        }

        /// `x` wrapped into `[−½, n − ½)` as `domain::wrap1` does within a
        /// period of it (one add or subtract of `n`), and the lanes further
        /// out (left to the reference, which takes the remainder).
        #[inline(always)]
        fn wrap_box(x: F, n: usize) -> (F, M) {
            let (lo, len) = (splat(-0.5), splat(n as f32));
            let hi = splat(-0.5 + n as f32);
            let (below, above) = (lt(x, lo), ge(x, hi));
            let (up, down) = (add(x, len), sub(x, len));
            let far = or(and(below, lt(up, lo)), and(above, ge(down, hi)));
            (sel(below, up, sel(above, down, x)), far)
        }

        /// [`super::points`] with backtrace `BT`.
        #[inline(never)]
        $(#[$tf])*
        fn points_traced<const BT: u8>(
            vel: &Vel,
            dt: f32,
            backtrace: Backtrace,
            g: &mut [Vec3],
            into_box: Option<[usize; 3]>,
        ) {
            for i in (0..g.len()).step_by(W) {
                let n = (g.len() - i).min(W);
                let group = &mut g[i..i + n];
                let c = coordinates(group, n);
                let (u0, bad0) = velocity(vel, c);
                let (mut p, bad) = trace::<BT>(vel, c, u0, dt);
                let mut bad = or(bad0, bad);
                if let Some(dims) = into_box {
                    for a in 0..3 {
                        let (y, far) = wrap_box(p[a], dims[a]);
                        p[a] = y;
                        bad = or(bad, far);
                    }
                }
                let left = bits(bad) & low_lanes(n);
                set_points(group, p, n, left);
                for l in lanes_in(left) {
                    group[l] = point_by_reference(vel, (dt, backtrace), group[l], into_box);
                }
            }
        }

        /// See [`super::points`].
        $(#[$tf])*
        pub(super) fn points(
            vel: &Vel,
            dt: f32,
            backtrace: Backtrace,
            g: &mut [Vec3],
            into_box: Option<[usize; 3]>,
        ) {
            match backtrace {
                Backtrace::Euler => points_traced::<EULER>(vel, dt, backtrace, g, into_box),
                Backtrace::Rk2 => points_traced::<RK2>(vel, dt, backtrace, g, into_box),
                Backtrace::Rk3 => points_traced::<RK3>(vel, dt, backtrace, g, into_box),
                Backtrace::Exact => unreachable!("the exact path takes the reference"),
            }
        }

        /// See [`super::velocities`].
        $(#[$tf])*
        pub(super) fn velocities(vel: &Vel, g: &[Vec3], out: &mut [Vec3]) {
            for i in (0..g.len()).step_by(W) {
                let n = (g.len() - i).min(W);
                let (u, bad) = velocity(vel, coordinates(&g[i..], n));
                let left = bits(bad) & low_lanes(n);
                set_points(&mut out[i..], u, n, left);
                for l in lanes_in(left) {
                    out[i + l] = vel.sampler.at(g[i + l]);
                }
            }
        }
    };
}
