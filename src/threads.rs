//! Running independent pieces of work on the threads a caller asked for: None, all cores;
//! Some(1), this thread only, in order; Some(k), a pool of k.
//!
//! The pools are tetrace's own, not rayon's global one: built on first use, kept per thread
//! count, and keyed by the process id, so that a child forked after a cast (Python's
//! `multiprocessing` on Linux, `os.fork()`) builds fresh pools instead of waiting forever on
//! worker threads that do not exist in it (a forked child has only the thread that forked).
//!
//! A caller may install a *poll* ([`with_poll`]): while its pieces run, the calling thread
//! calls it every [`POLL_EVERY`] with the pieces done and their number; when it answers
//! false, pieces not yet started are skipped and the run ends with [`Error::Interrupted`] once
//! the running ones finish. Long steps outside pieces (a scene's build) call [`checkpoint`]
//! between their stages, which polls the same way with no count. The Python bindings poll
//! Python's signal handlers this way, so Ctrl-C stops a cast, and report a cast's progress.

use crate::error::{Error, Result};
use rayon::prelude::*;
use rayon::ThreadPool;
use std::cell::{Cell, RefCell};
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
/// that pool (fork-safe) rather than rayon's global one. With a poll installed on this
/// thread, this thread polls while `f` runs on the pool, and once the poll says stop, every
/// [`checkpoint`] `f` reaches returns [`Error::Interrupted`]; so does this call, whatever `f`
/// returned.
pub fn install<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> Result<T> {
    let pool = pool(threads)?;
    let Some(poll) = current_poll() else {
        return Ok(pool.install(f));
    };
    let stop = Arc::new(AtomicBool::new(false));
    let (finished, out) = (AtomicBool::new(false), Mutex::new(None));
    let caller = std::thread::current();
    let mut interrupted = false;
    pool.in_place_scope(|s| {
        let (cancel, finished, out, caller) = (stop.clone(), &finished, &out, &caller);
        s.spawn(move |_| {
            struct Wake<'a>(&'a AtomicBool, &'a std::thread::Thread);
            impl Drop for Wake<'_> {
                fn drop(&mut self) {
                    self.0.store(true, Ordering::Release);
                    self.1.unpark();
                }
            }
            let _wake = Wake(finished, caller);
            let r = with_cancel(cancel, f);
            *out.lock().unwrap_or_else(|e| e.into_inner()) = Some(r);
        });
        while !finished.load(Ordering::Acquire) {
            std::thread::park_timeout(POLL_EVERY);
            if !finished.load(Ordering::Acquire) && !interrupted && !poll(NO_COUNT) {
                interrupted = true;
                stop.store(true, Ordering::Relaxed);
            }
        }
    });
    let r = out.into_inner().unwrap_or_else(|e| e.into_inner());
    match r {
        Some(r) if !interrupted => Ok(r),
        // Stopped (or `f` panicked, which the scope has re-raised before this point).
        _ => Err(Error::Interrupted),
    }
}

/// Runs `f` with `stop` as this thread's cancel flag (read by [`checkpoint`]).
fn with_cancel<T>(stop: Arc<AtomicBool>, f: impl FnOnce() -> T) -> T {
    struct Restore(Option<Arc<AtomicBool>>);
    impl Drop for Restore {
        fn drop(&mut self) {
            let old = self.0.take();
            CANCEL.with(|c| *c.borrow_mut() = old);
        }
    }
    let _restore = Restore(CANCEL.with(|c| c.borrow_mut().replace(stop)));
    f()
}

/// How far a run of pieces has come: `done` of `total` pieces (`total` 0: a [`checkpoint`],
/// which has no count).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    pub done: usize,
    pub total: usize,
}

type Poll = Rc<dyn Fn(Progress) -> bool>;

thread_local! {
    static POLL: RefCell<Option<Poll>> = const { RefCell::new(None) };
    /// When this thread's poll was last called by [`checkpoint`].
    static LAST_CHECKPOINT: Cell<Option<Instant>> = const { Cell::new(None) };
    /// Set on a pool thread running an [`install`]ed step whose caller polls: true once the
    /// caller's poll said stop.
    static CANCEL: RefCell<Option<Arc<AtomicBool>>> = const { RefCell::new(None) };
}

/// A poll's argument at a [`checkpoint`] or while an [`install`]ed step runs: no count.
const NO_COUNT: Progress = Progress { done: 0, total: 0 };

/// Runs `f` with `poll` installed on this thread (see the module's notes); the previous poll,
/// if any, is restored afterwards, even if `f` panics.
pub fn with_poll<T>(poll: impl Fn(Progress) -> bool + 'static, f: impl FnOnce() -> T) -> T {
    struct Restore(Option<Poll>, Option<Instant>);
    impl Drop for Restore {
        fn drop(&mut self) {
            let old = self.0.take();
            POLL.with(|p| *p.borrow_mut() = old);
            LAST_CHECKPOINT.with(|c| c.set(self.1));
        }
    }
    let old = POLL.with(|p| p.borrow_mut().replace(Rc::new(poll)));
    let last = LAST_CHECKPOINT.with(|c| c.replace(Some(Instant::now())));
    let _restore = Restore(old, last);
    f()
}

/// This thread's poll, if one is installed.
fn current_poll() -> Option<Poll> {
    POLL.with(|p| p.borrow().clone())
}

/// Between the stages of a long step that runs outside [`run_pieces`] (a scene's build, a GPU
/// cast's batches): [`Error::Interrupted`] when this thread's poll, called at most every
/// [`POLL_EVERY`], says stop, or (on a pool thread running an [`install`]ed step) when the
/// caller's poll has said so; Ok without either.
pub fn checkpoint() -> Result<()> {
    if CANCEL.with(|c| {
        c.borrow()
            .as_ref()
            .is_some_and(|s| s.load(Ordering::Relaxed))
    }) {
        return Err(Error::Interrupted);
    }
    let Some(poll) = current_poll() else {
        return Ok(());
    };
    let due = LAST_CHECKPOINT.with(|c| c.get().is_none_or(|t| t.elapsed() >= POLL_EVERY));
    if !due {
        return Ok(());
    }
    LAST_CHECKPOINT.with(|c| c.set(Some(Instant::now())));
    if poll(NO_COUNT) {
        Ok(())
    } else {
        Err(Error::Interrupted)
    }
}

/// Runs `work` on every piece (each piece once, in any order unless on one thread). With a
/// poll installed on this thread, stops early with [`Error::Interrupted`] when it says so.
///
/// A run of more than one piece also polls once before its first piece (done 0): a run that
/// ends within a poll period still reports, and a stop asked for before the start (Ctrl-C, a
/// progress callback that raises) stops it whatever the machine's speed. That costs one poll
/// per run of several pieces (a cast of more than one chunk of rays, `scene::cast::CHUNK`); a
/// run of one piece is not polled at its start.
pub fn run_pieces<T: Send>(
    pieces: Vec<T>,
    threads: Option<usize>,
    work: impl Fn(T) + Sync + Send,
) -> Result<()> {
    check_threads(threads)?;
    let poll = current_poll();
    let total = pieces.len();
    if let Some(poll) = &poll {
        if total > 1 && !poll(Progress { done: 0, total }) {
            return Err(Error::Interrupted);
        }
    }
    if threads == Some(1) {
        let mut last = Instant::now();
        for (done, p) in pieces.into_iter().enumerate() {
            if let Some(poll) = &poll {
                if last.elapsed() >= POLL_EVERY {
                    if !poll(Progress { done, total }) {
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
    let n = total;
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
            let so_far = done.load(Ordering::Acquire);
            if so_far < n
                && !interrupted
                && !poll(Progress {
                    done: so_far,
                    total: n,
                })
            {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The poll sees the pieces done grow to (at most) their number, on one thread and on a
    /// pool; every piece runs once.
    #[test]
    fn poll_sees_progress() {
        for threads in [Some(1), Some(2)] {
            let seen = Rc::new(RefCell::new(Vec::<Progress>::new()));
            let log = seen.clone();
            let ran = AtomicUsize::new(0);
            let out = with_poll(
                move |p| {
                    log.borrow_mut().push(p);
                    true
                },
                || {
                    run_pieces((0..40).collect(), threads, |_: usize| {
                        std::thread::sleep(Duration::from_millis(8));
                        ran.fetch_add(1, Ordering::Relaxed);
                    })
                },
            );
            assert!(out.is_ok());
            assert_eq!(ran.load(Ordering::Relaxed), 40);
            let seen = seen.borrow();
            assert!(
                !seen.is_empty(),
                "{threads:?}: polled while 40 pieces of 8 ms ran"
            );
            assert!(seen.iter().all(|p| p.total == 40 && p.done < 40));
            assert!(seen.windows(2).all(|w| w[0].done <= w[1].done));
        }
    }

    /// A run of several pieces polls once before its first piece, so a poll that says stop
    /// then runs none of them, however fast they would be; a run of one piece is not polled
    /// at its start.
    #[test]
    fn poll_at_the_start_of_a_run() {
        for threads in [Some(1), Some(2)] {
            // Pieces run and polls seen by a run of `n` pieces under a poll that says stop.
            let run = |n: usize| {
                let seen = Rc::new(RefCell::new(Vec::<Progress>::new()));
                let (log, ran) = (seen.clone(), AtomicUsize::new(0));
                let stop = move |p| {
                    log.borrow_mut().push(p);
                    false
                };
                let out = with_poll(stop, || {
                    run_pieces(vec![(); n], threads, |()| {
                        ran.fetch_add(1, Ordering::Relaxed);
                    })
                });
                let seen = seen.borrow().clone();
                (out, ran.into_inner(), seen)
            };
            let (out, ran, seen) = run(3);
            assert!(matches!(out, Err(Error::Interrupted)), "{threads:?}");
            assert_eq!((ran, &seen[..]), (0, &[Progress { done: 0, total: 3 }][..]));
            let (out, ran, seen) = run(1);
            assert!(out.is_ok(), "{threads:?}");
            assert_eq!((ran, seen.len()), (1, 0), "{threads:?}");
        }
    }

    /// A poll that says stop ends the run with Interrupted, and pieces not started are skipped.
    #[test]
    fn poll_stops_pieces() {
        for threads in [Some(1), Some(2)] {
            let ran = AtomicUsize::new(0);
            let out = with_poll(
                |_| false,
                || {
                    run_pieces((0..200).collect(), threads, |_: usize| {
                        std::thread::sleep(Duration::from_millis(5));
                        ran.fetch_add(1, Ordering::Relaxed);
                    })
                },
            );
            assert!(matches!(out, Err(Error::Interrupted)));
            assert!(ran.load(Ordering::Relaxed) < 200);
        }
    }

    /// A checkpoint polls (without a count) once POLL_EVERY has passed, and not before; it
    /// passes without a poll installed.
    #[test]
    fn checkpoint_polls_when_due() {
        assert!(checkpoint().is_ok());
        let calls = Rc::new(Cell::new(0));
        let c = calls.clone();
        let out = with_poll(
            move |p| {
                assert_eq!(p, Progress { done: 0, total: 0 });
                c.set(c.get() + 1);
                false
            },
            || {
                // Just installed: not yet due.
                assert!(checkpoint().is_ok());
                std::thread::sleep(POLL_EVERY + Duration::from_millis(10));
                checkpoint()
            },
        );
        assert!(matches!(out, Err(Error::Interrupted)));
        assert_eq!(calls.get(), 1);
        assert!(checkpoint().is_ok(), "the poll is gone after with_poll");
    }

    /// An installed step runs on the pool while the caller polls: its checkpoints see the
    /// caller's stop (within a poll period), and the call returns Interrupted; with a poll
    /// that says go on, the step's value comes back.
    #[test]
    fn installed_steps_see_the_callers_stop() {
        let started = Instant::now();
        let out = with_poll(
            |_| false,
            || {
                install(Some(2), || {
                    while started.elapsed() < Duration::from_secs(10) {
                        checkpoint()?;
                        std::thread::sleep(Duration::from_millis(1));
                    }
                    Ok::<_, Error>(7)
                })
            },
        );
        assert!(matches!(out, Err(Error::Interrupted)), "{out:?}");
        assert!(
            started.elapsed() < Duration::from_secs(2),
            "stopped within a poll period"
        );
        let out = with_poll(|_| true, || install(Some(2), || 7));
        assert_eq!(out.ok(), Some(7));
        assert_eq!(
            install(Some(2), checkpoint).ok().map(|r| r.is_ok()),
            Some(true)
        );
    }
}
