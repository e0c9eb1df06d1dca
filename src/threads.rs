//! Running independent pieces of work on the threads a caller asked for: None, all cores
//! (rayon's global pool); Some(1), this thread only, in order; Some(k), a pool of k.

use crate::error::{Error, Result};
use rayon::prelude::*;

/// Runs `work` on every piece (each piece once, in any order unless on one thread).
pub fn run_pieces<T: Send>(
    pieces: Vec<T>,
    threads: Option<usize>,
    work: impl Fn(T) + Sync + Send,
) -> Result<()> {
    match threads {
        Some(0) => {
            return Err(Error::InvalidOption(
                "threads must be at least 1 (or None for all cores)".into(),
            ))
        }
        Some(1) => pieces.into_iter().for_each(work),
        None => pieces.into_par_iter().for_each(work),
        Some(k) => rayon::ThreadPoolBuilder::new()
            .num_threads(k)
            .build()
            .map_err(|e| Error::InvalidOption(format!("cannot start {k} threads: {e}")))?
            .install(|| pieces.into_par_iter().for_each(work)),
    }
    Ok(())
}
