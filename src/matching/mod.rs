//! (matching: to be written)
