//! Per-ray status codes, shared with Python (`tetrace.MISS`, ...): the one table of them.
//! `tests/test_tables.py` checks that Python's codes and names are these.

pub const MISS: u8 = 0;
pub const HIT: u8 = 1;
/// The walk could not finish (step guard, or no tet found for the start point).
pub const FAILED: u8 = 2;
/// The ray itself is unusable: a non-finite component or a zero-length direction.
pub const INVALID: u8 = 3;

/// The codes' names, indexed by code (`tetrace.STATUS_NAMES`).
pub const STATUS_NAMES: [&str; 4] = ["miss", "hit", "failed", "invalid"];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_indexed_by_code() {
        assert_eq!(STATUS_NAMES[MISS as usize], "miss");
        assert_eq!(STATUS_NAMES[HIT as usize], "hit");
        assert_eq!(STATUS_NAMES[FAILED as usize], "failed");
        assert_eq!(STATUS_NAMES[INVALID as usize], "invalid");
    }
}
