//! Cross-crate integration and snapshot tests of the sdae workspace (see `tests/tests/`).
//!
//! The README's library example runs as a doctest of this crate, so it stays true.
#![doc = include_str!("../../README.md")]
