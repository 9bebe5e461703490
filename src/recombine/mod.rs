//! (recombine: to be written)
