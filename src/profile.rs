//! Developer hooks: where the time goes and what the optimizer rolled back, delivered to a
//! [`Trace`] sink the caller sets in [`Options::trace`](crate::Options::trace). The
//! library does no I/O of its own for them: the command line turns the events into stderr
//! lines (`BLOSSOMQUAD_STAGE_TIMES`) or graph files (`BLOSSOMQUAD_DUMP_GRAPHS`). With no
//! sink set, no clock is read.

use std::sync::Arc;
use std::time::Instant;

/// One event of a traced run.
#[derive(Debug)]
#[non_exhaustive]
pub enum TraceEvent<'a> {
    /// The stages of one step (`group`, e.g. "graph", "optimize") of one surface (0 when
    /// the step covers several) took these CPU seconds (whole process, all threads) and
    /// wall seconds, in order.
    StageTimes {
        /// What was timed.
        group: &'static str,
        /// Surface entity tag, or 0.
        surface: i32,
        /// `(stage, cpu seconds, wall seconds)`.
        laps: &'a [(&'static str, f64, f64)],
    },
    /// An optimizer stage left `count` invalid quads on `surface`; the surface went back to
    /// its last valid state. `quads` holds the node tags of up to four of them.
    Rollback {
        /// Surface entity tag.
        surface: i32,
        /// The optimizer stage, e.g. "smoothing".
        stage: &'a str,
        /// How many quads were invalid.
        count: usize,
        /// Node tags of the first few.
        quads: &'a [[u64; 4]],
    },
    /// The quads of one surface after an optimizer stage (sent with the stage times, so
    /// what each stage gains can be read beside what it costs).
    StageQuality {
        /// The timed step, e.g. "optimize".
        group: &'static str,
        /// Surface entity tag.
        surface: i32,
        /// The stage just ended, e.g. "smooth".
        stage: &'static str,
        /// Alive quads.
        quads: usize,
        /// Worst η (eq. 3).
        eta_worst: f64,
        /// Mean η.
        eta_mean: f64,
        /// Percentage of interior vertices with four quads.
        d4_percent: f64,
    },
    /// The matching graph of one surface, before it is solved: `vertices` triangles, edges
    /// `(u, v, cost)` (the input of `matching::solve`).
    MatchingGraph {
        /// Surface entity tag.
        surface: i32,
        /// Number of graph vertices (triangles).
        vertices: usize,
        /// The edges.
        edges: &'a [(u32, u32, i64)],
    },
}

/// A sink for [`TraceEvent`]s; called from worker threads, so it must be `Send + Sync`.
#[derive(Clone)]
pub struct Trace(Arc<dyn Fn(&TraceEvent<'_>) + Send + Sync>);

impl Trace {
    /// A sink calling `f` for every event.
    pub fn new(f: impl Fn(&TraceEvent<'_>) + Send + Sync + 'static) -> Self {
        Trace(Arc::new(f))
    }

    /// Delivers `event`.
    pub fn emit(&self, event: &TraceEvent<'_>) {
        (self.0)(event)
    }
}

impl std::fmt::Debug for Trace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Trace(..)")
    }
}

impl PartialEq for Trace {
    /// The same sink.
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

/// User + system CPU seconds of this process so far, all threads (0 where the platform
/// does not tell).
pub fn cpu_seconds() -> f64 {
    cpu_time::ProcessTime::try_now()
        .map(|t| t.as_duration().as_secs_f64())
        .unwrap_or(0.0)
}

/// Laps of one step, sent as [`TraceEvent::StageTimes`] by [`StageTimer::done`]; does
/// nothing without a sink.
pub(crate) struct StageTimer<'t> {
    trace: Option<&'t Trace>,
    group: &'static str,
    surface: i32,
    cpu: f64,
    wall: Instant,
    laps: Vec<(&'static str, f64, f64)>,
}

impl<'t> StageTimer<'t> {
    /// A timer for step `group` of surface `surface` (0: several).
    pub(crate) fn new(trace: Option<&'t Trace>, group: &'static str, surface: i32) -> Self {
        StageTimer {
            trace,
            group,
            surface,
            cpu: if trace.is_some() { cpu_seconds() } else { 0.0 },
            wall: Instant::now(),
            laps: Vec::new(),
        }
    }

    /// Ends stage `name` (started at the previous lap or at creation).
    pub(crate) fn lap(&mut self, name: &'static str) {
        if self.trace.is_some() {
            let c = cpu_seconds();
            let w = Instant::now();
            self.laps
                .push((name, c - self.cpu, (w - self.wall).as_secs_f64()));
            self.cpu = c;
            self.wall = w;
        }
    }

    /// The sink, when there is one.
    pub(crate) fn trace(&self) -> Option<&'t Trace> {
        self.trace
    }

    /// The step's name and surface.
    pub(crate) fn step(&self) -> (&'static str, i32) {
        (self.group, self.surface)
    }

    /// Restarts the clocks without a lap: what ran since the last lap is billed to no
    /// stage (the trace's own measurements).
    pub(crate) fn restart(&mut self) {
        if self.trace.is_some() {
            self.cpu = cpu_seconds();
            self.wall = Instant::now();
        }
    }

    /// Sends the laps.
    pub(crate) fn done(&self) {
        if let Some(t) = self.trace {
            t.emit(&TraceEvent::StageTimes {
                group: self.group,
                surface: self.surface,
                laps: &self.laps,
            });
        }
    }
}
