"""The mutation run's reach finder puts an abort first in every function body and nowhere else
(``tetrace.dev.mutants_reach``; docs/testing.md). A body it missed would let the run skip a test
that runs that body, and a mutant there would be reported missed when a test catches it."""

from tetrace.dev.mutants_reach import instrument

ABORT = " std::process::abort();"

SOURCE = """\
/// fn in_a_doc_comment() {}
pub fn plain(a: u32) -> u32 {
    a + 1
}
pub(crate) fn generic<T: Copy>(x: &[T; 3]) -> [T; 3]
where
    T: Default,
{
    *x
}
fn returns_array() -> [u8; 3] { [1, 2, 3] }
trait Shape {
    fn area(&self) -> f64;
    fn sides(&self) -> [u8; 2] { [0, 0] }
}
const fn folded(x: u32) -> u32 { x * 2 }
pub unsafe fn raw(p: *const u8) -> u8 { *p }
fn outer() {
    fn inner() {}
    let f = |x: u32| x + 1;
    inner();
}
"""


def test_every_body_gets_an_abort_and_declarations_and_const_fns_none():
    out, count, consts = instrument(SOURCE)
    bodies = ["plain", "generic", "returns_array", "sides", "raw", "outer", "inner"]
    assert count == len(bodies)
    assert consts == ["folded"]
    for name in bodies:
        head = out[out.index(f"fn {name}") :]
        assert head[head.index("{") + 1 :].startswith(ABORT), name
    # The required method (no body) and the const fn are left alone, as is the doc comment.
    assert "fn area(&self) -> f64;" in out
    assert "const fn folded(x: u32) -> u32 { x * 2 }" in out
    assert "/// fn in_a_doc_comment() {}" in out
    # Nothing else changes: removing the aborts gives the source back.
    assert out.replace(ABORT, "") == SOURCE
    # `where` clauses and array types in signatures: the abort opens the body, not a bracket.
    assert "[T; 3]\nwhere\n    T: Default,\n{" + ABORT in out
    assert "-> [u8; 3] {" + ABORT in out
