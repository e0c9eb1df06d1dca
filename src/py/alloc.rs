//! The extension's allocator: the system's, except that large blocks freed are kept a while
//! for the next allocation of the same size.
//!
//! Why: a cast's answer columns are vectors handed to numpy, freed when the user drops the
//! arrays, and allocated again by the next cast. glibc serves blocks this large by `mmap`
//! and gives them back by `munmap` (or trims them off its heap), so every cast of a million
//! rays touched about 37 MB of fresh pages: 9,190 page faults a cast, 25–30 ns a ray on the
//! 2-core VM, a fifth of a random ray's whole time (`docs/performance.md`). The same casts
//! with glibc told to keep its memory (`MALLOC_TRIM_THRESHOLD_`, `MALLOC_MMAP_THRESHOLD_`)
//! faulted none. Setting those for the whole Python process would change how every other
//! library's memory is given back; this keeps only the extension's own large blocks, up to
//! [`KEEP`] bytes by default, the oldest given back first. `tetrace.memory_cache(limit)`
//! changes the bound (0 keeps nothing and gives back what is kept).
//!
//! Blocks are reused only for the same size and alignment (the next cast of as many rays
//! asks for exactly the sizes the last one freed), so a kept block is always handed out
//! with the layout it was made with, and `dealloc` gets that layout back.

use pyo3::prelude::*;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Blocks of at least this many bytes are kept when freed (glibc's own heap already reuses
/// smaller ones without faults).
pub const LARGE: usize = 1 << 20;
/// At most this many bytes of freed blocks are kept, unless changed.
pub const KEEP: usize = 256 << 20;
/// At most this many blocks are kept (a cast frees about a dozen).
const SLOTS: usize = 64;

/// A freed block kept for reuse.
#[derive(Clone, Copy)]
struct Block {
    ptr: *mut u8,
    layout: Layout,
}

/// The kept blocks, oldest first, in a fixed array: the allocator must not allocate.
struct Kept {
    blocks: [Option<Block>; SLOTS],
    len: usize,
    bytes: usize,
}

// SAFETY: the pointers are blocks no one else holds; they move between threads only under
// the mutex.
unsafe impl Send for Kept {}

/// [`System`] with freed blocks of [`LARGE`] bytes or more kept for reuse.
pub struct KeepLarge {
    kept: Mutex<Kept>,
    limit: AtomicUsize,
}

impl KeepLarge {
    pub const fn new() -> KeepLarge {
        KeepLarge {
            kept: Mutex::new(Kept {
                blocks: [None; SLOTS],
                len: 0,
                bytes: 0,
            }),
            limit: AtomicUsize::new(KEEP),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Kept> {
        // Nothing panics while the lock is held, but a poisoned lock still guards valid data.
        self.kept.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// A kept block of exactly this layout, the newest, taken out of the cache.
    fn take(&self, layout: Layout) -> Option<*mut u8> {
        let mut k = self.lock();
        let i = (0..k.len)
            .rev()
            .find(|&i| k.blocks[i].is_some_and(|b| b.layout == layout))?;
        Some(k.remove(i).ptr)
    }

    /// Keeps a freed block, giving back the oldest while more than the limit's bytes or
    /// [`SLOTS`] blocks would be kept. A block larger than the limit is given back at once.
    fn keep(&self, ptr: *mut u8, layout: Layout) {
        let limit = self.limit.load(Ordering::Relaxed);
        if layout.size() > limit {
            // SAFETY: the caller's block, made by System with this layout.
            unsafe { System.dealloc(ptr, layout) };
            return;
        }
        let evicted = {
            let mut k = self.lock();
            let evicted = k.evict(limit - layout.size(), SLOTS - 1);
            let len = k.len;
            k.blocks[len] = Some(Block { ptr, layout });
            k.len += 1;
            k.bytes += layout.size();
            evicted
        };
        give_back(evicted);
    }

    /// Sets the bound on the bytes kept, gives back the oldest blocks above it, and returns
    /// the bound before.
    pub fn set_limit(&self, limit: usize) -> usize {
        let before = self.limit.swap(limit, Ordering::Relaxed);
        let evicted = self.lock().evict(limit, SLOTS);
        give_back(evicted);
        before
    }

    /// How many blocks and bytes are kept now, and the bound on the bytes.
    pub fn kept(&self) -> (usize, usize, usize) {
        let k = self.lock();
        (k.len, k.bytes, self.limit.load(Ordering::Relaxed))
    }
}

impl Default for KeepLarge {
    fn default() -> Self {
        KeepLarge::new()
    }
}

impl Kept {
    /// Takes block `i` (< len) out, the younger ones moving down to keep the order.
    fn remove(&mut self, i: usize) -> Block {
        let len = self.len;
        let block = self.blocks[i].take().expect("blocks below len are kept");
        self.blocks.copy_within(i + 1..len, i);
        self.blocks[len - 1] = None;
        self.len -= 1;
        self.bytes -= block.layout.size();
        block
    }

    /// Takes out the oldest blocks until at most `bytes` and `blocks` are kept, returning
    /// them to be given back once the lock is released.
    fn evict(&mut self, bytes: usize, blocks: usize) -> [Option<Block>; SLOTS] {
        let mut evicted = [None; SLOTS];
        let mut n = 0;
        while self.len > 0 && (self.len > blocks || self.bytes > bytes) {
            evicted[n] = Some(self.remove(0));
            n += 1;
        }
        evicted
    }
}

/// Gives blocks taken out of the cache back to the system.
fn give_back(blocks: [Option<Block>; SLOTS]) {
    for b in blocks.into_iter().flatten() {
        // SAFETY: kept blocks were made by System with their layout and are held by no one.
        unsafe { System.dealloc(b.ptr, b.layout) };
    }
}

/// The freed memory the extension keeps for reuse: `(blocks, bytes, limit)` now, after
/// setting the limit on the bytes kept to `limit` when given (0 keeps nothing).
#[pyfunction]
#[pyo3(signature = (limit=None))]
pub(crate) fn memory_cache(limit: Option<usize>) -> (usize, usize, usize) {
    if let Some(limit) = limit {
        super::ALLOC.set_limit(limit);
    }
    super::ALLOC.kept()
}

// SAFETY: every block handed out is either System's own or a kept block of exactly the
// asked layout, made by System and held by no one else; every block freed goes back to
// System or into the cache with the layout it was made with.
unsafe impl GlobalAlloc for KeepLarge {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() >= LARGE {
            if let Some(p) = self.take(layout) {
                return p;
            }
        }
        System.alloc(layout)
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if layout.size() >= LARGE {
            if let Some(p) = self.take(layout) {
                // Resident pages cleared cost far less than fresh ones faulted in.
                p.write_bytes(0, layout.size());
                return p;
            }
        }
        System.alloc_zeroed(layout)
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if layout.size() >= LARGE {
            self.keep(ptr, layout);
        } else {
            System.dealloc(ptr, layout);
        }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if layout.size() < LARGE && new_size < LARGE {
            return System.realloc(ptr, layout, new_size);
        }
        // SAFETY (of the layout): the caller guarantees new_size, rounded up to the
        // alignment, does not overflow isize.
        let new_layout = Layout::from_size_align_unchecked(new_size, layout.align());
        let new = self.alloc(new_layout);
        if !new.is_null() {
            std::ptr::copy_nonoverlapping(ptr, new, layout.size().min(new_size));
            self.dealloc(ptr, layout);
        }
        new
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The blocks and bytes kept.
    fn held(a: &KeepLarge) -> (usize, usize) {
        let (n, bytes, _) = a.kept();
        (n, bytes)
    }

    /// A block freed is handed out again for the same layout, zeroed when asked, and not
    /// for another size or alignment; the cache gives back its oldest blocks at its bounds.
    #[test]
    fn large_blocks_come_back_for_the_same_layout_only() {
        let a = KeepLarge::new();
        let big = Layout::from_size_align(3 * LARGE, 8).unwrap();
        let other = Layout::from_size_align(3 * LARGE + 8, 8).unwrap();
        let aligned = Layout::from_size_align(3 * LARGE, 4096).unwrap();
        unsafe {
            let p = a.alloc(big);
            assert!(!p.is_null());
            p.write_bytes(7, big.size());
            a.dealloc(p, big);
            assert_eq!(held(&a), (1, big.size()));
            let q = a.alloc(other);
            let r = a.alloc(aligned);
            assert!(q != p && r != p, "another layout got the kept block");
            assert_eq!(held(&a), (1, big.size()));
            let z = a.alloc_zeroed(big);
            assert_eq!(z, p, "the kept block was not reused");
            assert!(std::slice::from_raw_parts(z, big.size())
                .iter()
                .all(|&b| b == 0));
            assert_eq!(held(&a), (0, 0));
            a.dealloc(q, other);
            a.dealloc(r, aligned);
            a.dealloc(z, big);
            assert_eq!(held(&a), (3, 3 * big.size() + 8));
            // Small blocks pass straight through.
            let s = Layout::from_size_align(64, 8).unwrap();
            let t = a.alloc(s);
            a.dealloc(t, s);
            assert_eq!(held(&a).0, 3);
            // Bounded by bytes: blocks of a third of KEEP, the oldest given back first.
            let third = Layout::from_size_align(KEEP / 3, 8).unwrap();
            let ps: Vec<*mut u8> = (0..3).map(|_| a.alloc(third)).collect();
            for &p in &ps {
                a.dealloc(p, third);
            }
            let (n, bytes) = held(&a);
            assert!(bytes <= KEEP, "{bytes} bytes kept");
            assert_eq!(n, 3, "the three thirds, the older blocks given back");
            // A block larger than KEEP is given back at once.
            let huge = Layout::from_size_align(KEEP + 1, 8).unwrap();
            let h = a.alloc(huge);
            a.dealloc(h, huge);
            assert_eq!(held(&a).0, 3);
            // Bounded by count.
            let one = Layout::from_size_align(LARGE, 8).unwrap();
            let ps: Vec<*mut u8> = (0..SLOTS + 5).map(|_| a.alloc(one)).collect();
            for &p in &ps {
                a.dealloc(p, one);
            }
            assert_eq!(held(&a).0, SLOTS);
            assert!(held(&a).1 <= KEEP);
        }
    }

    /// Growing a vector across the threshold keeps its contents, whichever side it starts on.
    #[test]
    fn realloc_keeps_contents_across_the_threshold() {
        let a = KeepLarge::new();
        unsafe {
            let small = Layout::from_size_align(4096, 8).unwrap();
            let p = a.alloc(small);
            for i in 0..4096 {
                *p.add(i) = (i % 251) as u8;
            }
            let q = a.realloc(p, small, 2 * LARGE);
            let big = Layout::from_size_align(2 * LARGE, 8).unwrap();
            assert!((0..4096).all(|i| *q.add(i) == (i % 251) as u8));
            let r = a.realloc(q, big, 1000);
            assert!((0..1000).all(|i| *r.add(i) == (i % 251) as u8));
            a.dealloc(r, Layout::from_size_align(1000, 8).unwrap());
            assert_eq!(held(&a), (1, 2 * LARGE), "the big block is kept");
        }
    }

    /// A lower limit gives back the oldest blocks above it at once; 0 keeps nothing, and a
    /// block freed then goes straight back; the limit set is reported and can be restored.
    #[test]
    fn the_limit_gives_back_what_is_above_it() {
        let a = KeepLarge::new();
        let one = Layout::from_size_align(2 * LARGE, 8).unwrap();
        unsafe {
            let ps: Vec<*mut u8> = (0..4).map(|_| a.alloc(one)).collect();
            for &p in &ps {
                a.dealloc(p, one);
            }
            assert_eq!(held(&a), (4, 8 * LARGE));
            assert_eq!(a.set_limit(5 * LARGE), KEEP);
            assert_eq!(a.kept(), (2, 4 * LARGE, 5 * LARGE));
            // The newest two stay: the next allocation takes the newest.
            let newest = a.alloc(one);
            assert_eq!(newest, ps[3]);
            assert_eq!(a.set_limit(0), 5 * LARGE);
            assert_eq!(held(&a), (0, 0));
            a.dealloc(newest, one);
            assert_eq!(held(&a), (0, 0));
            a.set_limit(KEEP);
            let p = a.alloc(one);
            a.dealloc(p, one);
            assert_eq!(a.kept(), (1, 2 * LARGE, KEEP));
        }
    }
}
