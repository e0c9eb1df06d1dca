//! Per-ray status codes, shared with Python (`tetrace.MISS`, ...).

pub const MISS: u8 = 0;
pub const HIT: u8 = 1;
/// The walk could not finish (step guard, or no tet found for the start point).
pub const FAILED: u8 = 2;
/// The ray itself is unusable: a non-finite component or a zero-length direction.
pub const INVALID: u8 = 3;
