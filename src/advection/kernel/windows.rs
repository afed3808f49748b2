//! The corner fetch through row windows, once for AVX2 and AVX-512:
//! `windows!` expands it in an instruction set's module, which defines,
//! besides `body`'s lane types and primitives —
//!
//! - `WIDTH`: the values of a window, two vectors (`2 W`); `SLACK`: values
//!   before a lane's corner that its window starts at; `CONTIGUOUS_LOADS`:
//!   whether a stencil whose lanes' corners are consecutive is loaded as it
//!   is rather than through a window;
//! - `all`, `minus` (`a` and not `b`) on `M`, `ior` (bitwise or) on `I`,
//!   `none_of(v, mask)` (no lane of `v` has a bit of `mask`), `first` and `lane(v, l)` (lane 0, lane
//!   `l`), `merge` (`m`'s lanes of `a`, the others of `b`) and `gather`
//!   (`data[at]` in the lanes of a mask, bounds asserted);
//! - `Offset`, `offset(o)` and `permute(lo, hi, offset)`: per lane the
//!   value at offset `o` of `0..WIDTH` into the window `lo, hi` (AVX-512:
//!   one two-source permute; AVX2: two `vpermps` and a blend on the
//!   offset's bit 3, prepared once per stencil by `offset`);
//! - `unsafe fn loadp(p)`: `W` values from a pointer.
//!
//! The corners of a stencil come out of windows of `WIDTH` consecutive
//! values of a lattice row, found once in the first corner row and
//! shifted to the others; the lanes no window holds are gathered. Every
//! lane's value is the one `data[rows[r] + x[c]]` holds, however it is
//! fetched, so the fetch changes no bit of the kernel's result.

macro_rules! windows {
    ($(#[$tf:meta])*) => {
        /// Windows tried per stencil before the lanes left are gathered.
        const WINDOWS: usize = 3;

        /// Every lane.
        const FULL: u32 = (1 << W) - 1;

        /// [`Plan::windows`] of a stencil whose lanes' corners are consecutive.
        const CONTIGUOUS: u8 = 3;

        /// How a stencil's corners are fetched. When every lane's corner
        /// rows are the first one's shifted by `shifts` and one window of
        /// the first row (from `start[0]`) holds every lane's x0 and x1, or
        /// two do (the second from `start[1]` holding the x0 of the lanes
        /// `second[0]` and the x1 of `second[1]`: the lanes of a group fall
        /// in two lattice rows where the flow's floor changes along it, and
        /// a lane's x0 and x1 lie at either end of a row at a periodic
        /// seam), through them (`windows` 1 or 2); when the lanes' corners
        /// are consecutive, by plain loads (`windows` [`CONTIGUOUS`]);
        /// otherwise (`windows` 0) [`fetch_split`].
        #[derive(Clone, Copy)]
        struct Plan {
            shifts: Option<[usize; 4]>,
            start: [usize; 2],
            second: [M; 2],
            windows: u8,
        }

        /// The windows of a stencil on a lattice of `len` values: from
        /// [`SLACK`] before lane 0's x0, and if that does not hold every
        /// lane's corners, from [`SLACK`] before the first corner it does
        /// not hold.
        #[inline(always)]
        fn plan(len: usize, rows: [I; 4], x: [I; 2], shifts: Option<[i32; 4]>) -> Plan {
            let shifts = shifts.map(|s| s.map(|s| s as usize));
            let mut plan = Plan {
                shifts,
                start: [0; 2],
                second: [none(); 2],
                windows: 0,
            };
            let Some(rows_on) = shifts else {
                return plan;
            };
            let at = [iadd(rows[0], x[0]), iadd(rows[0], x[1])];
            // The usual case: lane l's x0 and x1 at lane 0's plus l (the
            // lanes' floors along x step with them), contiguous loads.
            let base = first(at[0]);
            let lane_ids = trunc(iota());
            let contiguous = and(
                ieq(isub(at[0], lane_ids), isplat(base)),
                ieq(isub(at[1], lane_ids), isplat(base + 1)),
            );
            if CONTIGUOUS_LOADS
                && bits(contiguous) == FULL
                && base >= 0
                && base as usize + rows_on[3] + W < len
            {
                (plan.start[0], plan.windows) = (base as usize, CONTIGUOUS);
                return plan;
            }
            let reach = rows_on[3] + WIDTH;
            if reach > len {
                return plan;
            }
            let last = (len - reach).min(i32::MAX as usize) as i32;
            let start = (base - SLACK).clamp(0, last);
            let from = isplat(start);
            plan.start[0] = start as usize;
            if none_of(ior(isub(at[0], from), isub(at[1], from)), !(WIDTH as i32 - 1)) {
                plan.windows = 1;
                return plan;
            }
            let one = held(at, start);
            let c = usize::from(bits(one[0]) == FULL);
            let second = (lane(at[c], (!bits(one[c])).trailing_zeros()) - SLACK).clamp(0, last);
            let two = held(at, second);
            if bits(and(or(one[0], two[0]), or(one[1], two[1]))) == FULL {
                let second_lanes = [minus(all(), one[0]), minus(all(), one[1])];
                (plan.start[1], plan.second, plan.windows) = (second as usize, second_lanes, 2);
            }
            plan
        }

        /// The lanes whose x0 and whose x1 (`at`) the window from `start`
        /// holds.
        #[inline(always)]
        fn held(at: [I; 2], start: i32) -> [M; 2] {
            let (from, last) = (isplat(start), isplat(WIDTH as i32 - 1));
            [ule(isub(at[0], from), last), ule(isub(at[1], from), last)]
        }

        /// The offsets from `start` of the stencil's x0 and x1 in its first
        /// row, prepared for [`permute`].
        #[inline(always)]
        fn offsets(row: I, x: [I; 2], start: usize) -> [Offset; 2] {
            let at = isub(row, isplat(start as i32));
            [offset(iadd(at, x[0])), offset(iadd(at, x[1]))]
        }

        /// The corners `data[rows[r] + x[c]]` of a stencil's four rows:
        /// through `plan`'s windows or contiguous loads in the usual case
        /// (two loads a row and window), else [`fetch_split`].
        ///
        /// # Panics
        /// If a window or a gathered lane lies outside `data`.
        #[inline(always)]
        fn fetch(data: &[f32], plan: Plan, rows: [I; 4], x: [I; 2]) -> [[F; 2]; 4] {
            let Some(shifts) = plan.shifts.filter(|_| plan.windows > 0) else {
                // (With `shifts`, only the first row is read.)
                let rows = match plan.shifts {
                    Some(_) => [rows[0]; 4],
                    None => rows,
                };
                // SAFETY: reached only from the kernel's entry points, which
                // carry this instruction set's `target_feature` (`prims!`).
                return unsafe { fetch_split(data, plan.shifts, rows, x) };
            };
            let [first, second] = plan.start;
            if plan.windows == CONTIGUOUS {
                assert!(
                    first + shifts[3] + W < data.len(),
                    "trilinear corners outside the data"
                );
                let mut v = [[splat(0.0); 2]; 4];
                for (v, s) in v.iter_mut().zip(shifts) {
                    // SAFETY: the rows' W + 1 values from `first` end inside
                    // (asserted), and the kernel's entry points alone reach
                    // here (`prims!`).
                    *v = unsafe {
                        let p = data.as_ptr().add(first + s);
                        [loadp(p), loadp(p.add(1))]
                    };
                }
                return v;
            }
            let reach = first.max(second) + shifts[3] + WIDTH;
            assert!(reach <= data.len(), "trilinear window outside the data");
            let window = |start: usize, o: [Offset; 2]| {
                // SAFETY: every window of the plan ends by `reach`
                // (asserted), and the kernel's entry points alone reach here
                // (`prims!`).
                let (lo, hi) = unsafe {
                    let p = data.as_ptr().add(start);
                    (loadp(p), loadp(p.add(W)))
                };
                [permute(lo, hi, o[0]), permute(lo, hi, o[1])]
            };
            let mut v = [[splat(0.0); 2]; 4];
            let o = offsets(rows[0], x, first);
            if plan.windows == 1 {
                for (v, s) in v.iter_mut().zip(shifts) {
                    *v = window(first + s, o);
                }
            } else {
                let o2 = offsets(rows[0], x, second);
                for (v, s) in v.iter_mut().zip(shifts) {
                    let [a, b] = window(first + s, o);
                    let [c, d] = window(second + s, o2);
                    *v = [merge(plan.second[0], c, a), merge(plan.second[1], d, b)];
                }
            }
            v
        }

        /// Windows of a row and the lanes they hold: `count` windows,
        /// window `n` from `start[n]` holding the x0 and x1 of the lanes
        /// `lanes[n]`; the lanes `left` are gathered.
        struct Windows {
            start: [usize; WINDOWS],
            lanes: [[M; 2]; WINDOWS],
            count: usize,
            left: [M; 2],
        }

        impl Windows {
            /// Windows for the corners `at`, each from [`SLACK`] before the
            /// first corner not yet held (an x0, then an x1: a lane's two
            /// corners lie in different windows at a periodic seam), up to
            /// [`WINDOWS`], none starting after `last` (none at all if
            /// `last` is `None`: the rows end before a window would).
            #[inline(always)]
            fn find(at: [I; 2], last: Option<i32>) -> Self {
                let mut w = Self {
                    start: [0; WINDOWS],
                    lanes: [[none(); 2]; WINDOWS],
                    count: 0,
                    left: [all(); 2],
                };
                let Some(last) = last else {
                    return w;
                };
                while w.count < WINDOWS && bits(or(w.left[0], w.left[1])) != 0 {
                    let c = usize::from(bits(w.left[0]) == 0);
                    let first = lane(at[c], bits(w.left[c]).trailing_zeros());
                    let start = (first - SLACK).clamp(0, last);
                    let from = isplat(start);
                    let top = isplat(WIDTH as i32 - 1);
                    let held = [
                        and(w.left[0], ule(isub(at[0], from), top)),
                        and(w.left[1], ule(isub(at[1], from), top)),
                    ];
                    if bits(or(held[0], held[1])) == 0 {
                        break;
                    }
                    w.start[w.count] = start as usize;
                    w.lanes[w.count] = held;
                    w.count += 1;
                    w.left = [minus(w.left[0], held[0]), minus(w.left[1], held[1])];
                }
                w
            }

            /// The corners `at` (of the row the windows were found in) of
            /// the row `shift` on.
            ///
            /// # Panics
            /// If a window or a gathered lane lies outside `data`.
            #[inline(always)]
            fn fetch(&self, data: &[f32], shift: usize, at: [I; 2]) -> [F; 2] {
                let mut v = [splat(0.0); 2];
                for n in 0..self.count {
                    let start = self.start[n];
                    let d = &data[start + shift..start + shift + WIDTH];
                    let (lo, hi) = (load(d), load(&d[W..]));
                    let from = isplat(start as i32);
                    let picked = |at: I| permute(lo, hi, offset(isub(at, from)));
                    v[0] = merge(self.lanes[n][0], picked(at[0]), v[0]);
                    v[1] = merge(self.lanes[n][1], picked(at[1]), v[1]);
                }
                for c in 0..2 {
                    if bits(self.left[c]) != 0 {
                        let a = iadd(at[c], isplat(shift as i32));
                        v[c] = gather(v[c], data, a, self.left[c]);
                    }
                }
                v
            }
        }

        /// [`fetch`] for stencils that one window does not hold: windows
        /// found in the first row and shifted to the others by `shifts`,
        /// or, when the rows differ across lanes (`shifts` `None`: wrapped
        /// or clamped along y or z), each row's own; gathers for the rest
        /// ([`Windows`]).
        #[inline(never)]
        $(#[$tf])*
        fn fetch_split(
            data: &[f32],
            shifts: Option<[usize; 4]>,
            rows: [I; 4],
            x: [I; 2],
        ) -> [[F; 2]; 4] {
            let mut v = [[splat(0.0); 2]; 4];
            let last = |reach: usize| {
                (data.len() >= reach).then(|| (data.len() - reach).min(i32::MAX as usize) as i32)
            };
            match shifts {
                Some(shifts) => {
                    let at = [iadd(rows[0], x[0]), iadd(rows[0], x[1])];
                    let w = Windows::find(at, last(shifts[3] + WIDTH));
                    for (v, s) in v.iter_mut().zip(shifts) {
                        *v = w.fetch(data, s, at);
                    }
                }
                None => {
                    for (v, r) in v.iter_mut().zip(rows) {
                        let at = [iadd(r, x[0]), iadd(r, x[1])];
                        *v = Windows::find(at, last(WIDTH)).fetch(data, 0, at);
                    }
                }
            }
            v
        }
    };
}
