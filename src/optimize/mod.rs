//! (optimize: to be written)
