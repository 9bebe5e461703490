//! The parts of a [`Report`](crate::Report) and of an [`Error`](crate::Error): what each
//! stage of [`quadrangulate`](crate::quadrangulate) reports, and why it refuses.

pub use crate::high_order::{HighOrderError, SecondOrderReport};
pub use crate::optimize::{
    OperationCounts, OptimizeError, OptimizeReport, Stats, SurfaceOptimizeReport,
};
pub use crate::pipeline::Times;
pub use crate::recombine::{
    EdgeSet, FallbackSplit, InvariantViolation, OddRegion, ParityMode, ParitySplit, RecombineError,
    RecombineReport, SurfaceReport, WalledFold,
};
pub use crate::refine::{RefineError, RefineReport};
pub use crate::renumber::{RenumberReport, TagMap};
pub use crate::validity::{BadQuad, Defect};
