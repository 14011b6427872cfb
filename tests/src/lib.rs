//! Cross-crate integration and snapshot tests of the sdae workspace (see `tests/tests/`).
