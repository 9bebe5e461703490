//! Quality measures of the paper's section 2: the quad quality η (eq. 3), and (to come) the
//! mesh statistics η_w, η̄, vertex degrees and the efficiency index τ (eq. 1-2).

pub mod eta;

pub use eta::{eta, eta_signed};
