//! Orderings of points and tets that make the walk touch memory in order.

pub mod hilbert;
