//! The one gate every progress report of a job passes (order, throttling; see
//! [`super::Progress`]).

use super::*;

/// Where the stages send their progress: forwards to a [`ProgressFn`] only what keeps the
/// promises of [`Progress`] (stage order, `done` not decreasing, a stage's reports from 0 to
/// `total`) and what moved by at least 1/[`Reporter::STEPS`] of the stage since the last
/// report, or ends it; one call at a time,
/// so reports from several threads arrive in order. A report of [`Stage::Topology`] at 0,
/// or of any stage at 0 after a finished [`Stage::Check`], starts a new round.
pub(super) struct Reporter {
    f: ProgressFn,
    /// The last report forwarded.
    last: std::sync::Mutex<Option<Progress>>,
}

impl Reporter {
    /// Reports per stage at most (plus the one that ends it).
    const STEPS: u64 = 200;

    /// A callback forwarding to `f` what is due.
    pub(crate) fn wrap(f: &ProgressFn) -> ProgressFn {
        let r = Reporter {
            f: f.clone(),
            last: std::sync::Mutex::new(None),
        };
        ProgressFn::new(move |p| r.report(p))
    }

    /// Forwards `p` if it is due (see the type's docs).
    pub(super) fn report(&self, p: Progress) {
        // a poisoned lock means a callback panicked: report nothing more
        let Ok(mut last) = self.last.lock() else {
            return;
        };
        // a stage's first report forwarded: preceded by one at 0 when it is past 0
        let mut starts = true;
        if let Some(l) = *last {
            // a fallback round starts again from the first stage, and a round that only
            // optimizes more surfaces (without `optimize`) from the optimizer, once the
            // checks that end a round are done
            let round_over = l.stage == Stage::Check && l.done == l.total;
            let restart = p.done == 0 && (p.stage == Stage::Topology || round_over);
            if p.stage < l.stage && !restart {
                return;
            }
            starts = p.stage != l.stage;
            if p.stage == l.stage {
                let ended = p.done == p.total && l.done < l.total;
                let moved = (p.fraction() - l.fraction()) * Self::STEPS as f64 >= 1.0;
                // the last surfaces may finish after the units are all done
                let last_surfaces = p.done == p.total && p.surfaces_done > l.surfaces_done;
                if p.fraction() < l.fraction() || !(ended || moved || last_surfaces) {
                    return;
                }
            } else if l.done < l.total && p.stage > l.stage {
                // a later stage started, so this one ended (its last report may have
                // been overtaken by another thread's)
                (self.f.0)(Progress {
                    done: l.total,
                    surfaces_done: l.surfaces,
                    ..l
                });
            }
        }
        if starts && p.done > 0 {
            // a stage starts at 0 (its first units may have been done before it is
            // reported, such as surfaces matched while another's graph was built)
            (self.f.0)(Progress {
                done: 0,
                surfaces_done: 0,
                ..p
            });
        }
        *last = Some(p);
        (self.f.0)(p);
    }
}
