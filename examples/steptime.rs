//! Temporary timing harness (not committed).
use smokelab::advection::Backtrace;
use smokelab::scenario::hot_cold::HotColdConfig;
use smokelab::scenario::{Scenario, SolverConfig};
use std::time::Instant;

fn cpu_ms() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap();
    let f: Vec<&str> = s.rsplit(')').next().unwrap().split_whitespace().collect();
    let t: f64 = f[11].parse::<f64>().unwrap() + f[12].parse::<f64>().unwrap();
    t * 10.0
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let res: usize = args.get(1).map_or(128, |s| s.parse().unwrap());
    let steps: usize = args.get(2).map_or(8, |s| s.parse().unwrap());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let which: Vec<Backtrace> = match args.get(3).map(|s| s.as_str()) {
        Some("euler") => vec![Backtrace::Euler],
        Some("rk2") => vec![Backtrace::Rk2],
        _ => vec![Backtrace::Euler, Backtrace::Rk2],
    };
    let mut sims: Vec<_> = which
        .iter()
        .map(|&bt| {
            let cfg = HotColdConfig {
                solver: SolverConfig {
                    res,
                    backtrace: bt,
                    ..SolverConfig::default()
                },
                ..Default::default()
            };
            let mut s = cfg.build().unwrap();
            pool.install(|| {
                for _ in 0..3 {
                    s.step()
                }
            });
            s
        })
        .collect();
    let mut t = vec![vec![]; sims.len()];
    let mut st = vec![vec![]; sims.len()];
    let mut cpu = vec![0.0; sims.len()];
    for _ in 0..steps {
        for (n, s) in sims.iter_mut().enumerate() {
            let t0 = Instant::now();
            let c0 = cpu_ms();
            pool.install(|| s.step());
            t[n].push(t0.elapsed().as_secs_f64() * 1e3);
            cpu[n] += cpu_ms() - c0;
            st[n].push([
                s.times.advect * 1e3,
                s.times.project * 1e3,
                s.times.force * 1e3,
            ]);
        }
    }
    for n in 0..sims.len() {
        let mut v = t[n].clone();
        v.sort_by(f64::total_cmp);
        let mut a: Vec<f64> = st[n].iter().map(|x| x[0]).collect();
        a.sort_by(f64::total_cmp);
        let mut p: Vec<f64> = st[n].iter().map(|x| x[1]).collect();
        p.sort_by(f64::total_cmp);
        println!("{:?} {res}: step {:.1} ms (min {:.1}) advect {:.1} (min {:.1}) project {:.1}; cpu/step {:.1} ms", which[n], v[v.len() / 2], v[0], a[a.len() / 2], a[0], p[p.len() / 2], cpu[n] / steps as f64);
    }
    let h: u64 = sims
        .iter()
        .flat_map(|s| {
            (0..3).flat_map(move |a| s.velocity.slice(a).iter().map(|x| x.to_bits() as u64))
        })
        .fold(0u64, |h, x| h.wrapping_mul(1_000_003).wrapping_add(x));
    println!("hash {h:x}");
}
