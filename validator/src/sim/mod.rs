//! The shadow reference simulator: decodes micromap data exactly as the
//! specification defines it and decides what traversal makes of a hit.
//! Pure functions over bytes and numbers; the checks feed them.

pub mod census;
pub mod decode;
pub mod index;
pub mod intersect;
pub mod keys;
pub mod opacity;
pub mod trace;
