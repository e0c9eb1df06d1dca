//! Tests of the crate as a whole rather than of one module. They live in the library (not in
//! `tests/*.rs`) so that `make test` compiles the crate once, as its own test harness, instead of
//! once more as the library that integration tests link to.

mod module_graph;
