//! (quality: to be written)
