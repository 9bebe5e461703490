//! Quad mesh optimization, the paper's section 6 (to be written).

pub mod synth;
