//! Geometry shared by every stage: the scalar trait, exact orientation, the exact ray predicates, the ray–box clip, the
//! ray–triangle hit and the orthonormal basis. Nothing here knows about tets.

pub mod dyadic;
pub mod exact;
pub mod narrow;
pub mod onb;
pub mod predicates;
pub mod ray;
pub mod real;
pub mod rounded;
pub mod triangle;
