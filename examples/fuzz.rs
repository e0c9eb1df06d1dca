//! Long fuzz runs on stable Rust (docs/fuzzing.md):
//!
//! ```text
//! cargo run --release --features fuzz --example fuzz -- --cases 1000000 [--target construct|walk] [--seed S]
//! ```
//!
//! Prints, per target, the cases run, panics, invariant violations, seconds and the slowest
//! case; exits 1 if any case failed (each failure names the seed that reproduces it:
//! `--replay SEED --target T` reruns that one case with the panic message shown). A watchdog
//! names the running case and exits 2 if it runs for more than 300 s (a hang).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tetrace::fuzz::{run, Target};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut cases: u64 = 100_000;
    let mut seed: u64 = 0;
    let mut targets = vec![Target::Construct, Target::Walk];
    let mut replay = None;
    let mut k = 0;
    while k < args.len() {
        let value = args.get(k + 1).cloned().unwrap_or_default();
        match args[k].as_str() {
            "--cases" => cases = value.parse().expect("--cases N"),
            "--seed" => seed = value.parse().expect("--seed S"),
            "--replay" => replay = Some(value.parse::<u64>().expect("--replay SEED")),
            "--target" => {
                targets = vec![match value.as_str() {
                    "construct" => Target::Construct,
                    "walk" => Target::Walk,
                    t => panic!("unknown target {t:?} (construct or walk)"),
                }]
            }
            a => panic!("unknown argument {a:?}"),
        }
        k += 2;
    }
    if let Some(s) = replay {
        for t in targets {
            println!("{} case {s}: {:?}", t.name(), t.case(s));
        }
        return;
    }
    // Panics are caught and counted; their messages are kept in the report, not printed.
    std::panic::set_hook(Box::new(|_| {}));
    let mut failed = false;
    for target in targets {
        let last = Arc::new(AtomicU64::new(Instant::now().elapsed().as_secs()));
        // The seed of the case running now (set before it starts: the first, then each next).
        let current = Arc::new(AtomicU64::new(tetrace::fuzz::case_seed(seed, 0)));
        let clock = Instant::now();
        {
            let (last, current) = (last.clone(), current.clone());
            std::thread::spawn(move || loop {
                std::thread::sleep(Duration::from_secs(5));
                let now = clock.elapsed().as_secs();
                if now.saturating_sub(last.load(Ordering::Relaxed)) > 300 {
                    eprintln!(
                        "{}: the case of seed {} ran past 300 s (a hang?)",
                        target.name(),
                        current.load(Ordering::Relaxed)
                    );
                    std::process::exit(2);
                }
            });
        }
        let r = run(target, seed, 0, cases, |i, s| {
            let _ = s;
            current.store(tetrace::fuzz::case_seed(seed, i + 1), Ordering::Relaxed);
            last.store(clock.elapsed().as_secs(), Ordering::Relaxed);
            if (i + 1) % 100_000 == 0 {
                eprintln!(
                    "{}: {} cases, {:.0} s",
                    target.name(),
                    i + 1,
                    clock.elapsed().as_secs_f64()
                );
            }
        });
        println!(
            "target {}: seed {seed}, cases {}, panics {}, violations {}, seconds {:.1}, \
             slowest case {:.3} s (seed {})",
            target.name(),
            r.cases,
            r.panics,
            r.violations,
            r.seconds,
            r.slowest.0,
            r.slowest.1
        );
        for f in &r.failures {
            println!(
                "  {} seed {}: {}",
                if f.panicked { "PANIC" } else { "VIOLATION" },
                f.seed,
                f.message
            );
        }
        failed |= !r.failures.is_empty();
    }
    if failed {
        std::process::exit(1);
    }
}
