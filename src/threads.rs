//! Running independent pieces of work on the threads a caller asked for: None, all cores;
//! Some(1), this thread only, in order; Some(k), a pool of k.
//!
//! The pools are tetrace's own, not rayon's global one: built on first use, kept per thread
//! count, and keyed by the process id, so that a child forked after a cast (Python's
//! `multiprocessing` on Linux, `os.fork()`) builds fresh pools instead of waiting forever on
//! worker threads that do not exist in it (a forked child has only the thread that forked).
//!
//! A caller may install a *poll* ([`with_poll`]): while its pieces run, the calling thread
//! calls it every [`POLL_EVERY`]; when it answers false, pieces not yet started are skipped
//! and the run ends with [`Error::Interrupted`] once the running ones finish. The Python
//! bindings poll Python's signal handlers this way, so Ctrl-C stops a cast.

use crate::error::{Error, Result};
use rayon::prelude::*;
use rayon::ThreadPool;
use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How often the calling thread asks its poll whether to go on.
pub const POLL_EVERY: Duration = Duration::from_millis(50);

/// The most threads a call may ask for: 4 per core, and at least 64 (more threads than that
/// only adds switching; a typo such as `threads=10**9` would start them all).
pub fn max_threads() -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    (4 * cores).max(64)
}

/// Refuses thread counts no pool should have (0, or above [`max_threads`]).
pub fn check_threads(threads: Option<usize>) -> Result<()> {
    match threads {
        Some(0) => Err(Error::InvalidOption(
            "threads must be at least 1 (or None for all cores)".into(),
        )),
        Some(k) if k > max_threads() => Err(Error::InvalidOption(format!(
            "threads must be at most {} (4 per core, at least 64), got {k}",
            max_threads()
        ))),
        _ => Ok(()),
    }
}

/// The pools of this process, by thread count (None: rayon's default count, all cores or
/// `RAYON_NUM_THREADS`).
struct Pools {
    pid: u32,
    by_count: HashMap<Option<usize>, Arc<ThreadPool>>,
}

static POOLS: Mutex<Option<Pools>> = Mutex::new(None);

/// The pool of `threads` threads of this process, built on first use (again in a forked
/// child: the parent's pools' threads are not there).
pub fn pool(threads: Option<usize>) -> Result<Arc<ThreadPool>> {
    check_threads(threads)?;
    let pid = std::process::id();
    let mut slot = POOLS.lock().unwrap_or_else(|e| e.into_inner());
    if slot.as_ref().is_some_and(|p| p.pid != pid) {
        // A forked child: the parent's pools have no threads here, and dropping them would
        // signal those threads through state copied mid-use. Leak them (a few words each).
        std::mem::forget(slot.take());
    }
    let pools = slot.get_or_insert_with(|| Pools {
        pid,
        by_count: HashMap::new(),
    });
    if let Some(p) = pools.by_count.get(&threads) {
        return Ok(p.clone());
    }
    let built = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .thread_name(|k| format!("tetrace-{k}"))
        .build()
        .map_err(|e| {
            Error::InvalidOption(format!(
                "cannot start {} threads: {e}",
                threads.map_or("the default number of".into(), |k| k.to_string())
            ))
        })?;
    let p = Arc::new(built);
    pools.by_count.insert(threads, p.clone());
    Ok(p)
}

/// Runs `f` inside the pool of `threads` threads, so that rayon's parallel iterators in it use
/// that pool (fork-safe) rather than rayon's global one.
pub fn install<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> Result<T> {
    Ok(pool(threads)?.install(f))
}

type Poll = Rc<dyn Fn() -> bool>;

thread_local! {
    static POLL: RefCell<Option<Poll>> = const { RefCell::new(None) };
}

/// Runs `f` with `poll` installed on this thread (see the module's notes); the previous poll,
/// if any, is restored afterwards, even if `f` panics.
pub fn with_poll<T>(poll: impl Fn() -> bool + 'static, f: impl FnOnce() -> T) -> T {
    struct Restore(Option<Poll>);
    impl Drop for Restore {
        fn drop(&mut self) {
            let old = self.0.take();
            POLL.with(|p| *p.borrow_mut() = old);
        }
    }
    let old = POLL.with(|p| p.borrow_mut().replace(Rc::new(poll)));
    let _restore = Restore(old);
    f()
}

/// This thread's poll, if one is installed.
fn current_poll() -> Option<Poll> {
    POLL.with(|p| p.borrow().clone())
}

/// Runs `work` on every piece (each piece once, in any order unless on one thread). With a
/// poll installed on this thread, stops early with [`Error::Interrupted`] when it says so.
pub fn run_pieces<T: Send>(
    pieces: Vec<T>,
    threads: Option<usize>,
    work: impl Fn(T) + Sync + Send,
) -> Result<()> {
    check_threads(threads)?;
    let poll = current_poll();
    if threads == Some(1) {
        let mut last = Instant::now();
        for p in pieces {
            if let Some(poll) = &poll {
                if last.elapsed() >= POLL_EVERY {
                    if !poll() {
                        return Err(Error::Interrupted);
                    }
                    last = Instant::now();
                }
            }
            work(p);
        }
        return Ok(());
    }
    let pool = pool(threads)?;
    let Some(poll) = poll else {
        pool.install(|| pieces.into_par_iter().for_each(work));
        return Ok(());
    };
    // The calling thread hands the pieces to the pool and polls until they are done.
    let n = pieces.len();
    let (stop, done) = (AtomicBool::new(false), AtomicUsize::new(0));
    let caller = std::thread::current();
    let mut interrupted = false;
    pool.in_place_scope(|s| {
        for p in pieces {
            let (work, stop, done, caller) = (&work, &stop, &done, &caller);
            s.spawn(move |_| {
                // Counted even if `work` panics (the scope re-raises the panic at its end).
                let _count = Done { done, n, caller };
                if !stop.load(Ordering::Relaxed) {
                    work(p);
                }
            });
        }
        while done.load(Ordering::Acquire) < n {
            std::thread::park_timeout(POLL_EVERY);
            if done.load(Ordering::Acquire) < n && !interrupted && !poll() {
                interrupted = true;
                stop.store(true, Ordering::Relaxed);
            }
        }
    });
    if interrupted {
        return Err(Error::Interrupted);
    }
    Ok(())
}

/// Counts a finished piece when dropped, and wakes the caller after the last.
struct Done<'a> {
    done: &'a AtomicUsize,
    n: usize,
    caller: &'a std::thread::Thread,
}

impl Drop for Done<'_> {
    fn drop(&mut self) {
        if self.done.fetch_add(1, Ordering::AcqRel) + 1 == self.n {
            self.caller.unpark();
        }
    }
}
