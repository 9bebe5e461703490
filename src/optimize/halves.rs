//! A topology pass on a large surface in two halves at once, then along the seam.
//!
//! The quads are in Morton order (`extract`), so the first and the second half of their
//! indices are two compact regions. Nodes in quads of both halves form the *seam*; the
//! *band* is every node within [`SEAM_RINGS`] quad rings of it. Each half becomes a
//! [`Local`] of its own (its quads, the nodes they use), and [`topo::pass`] runs on both
//! side by side with a focus that leaves the band out. Then a pass with the band as its
//! focus runs on a third `Local`: the quads with a node within [`SEAM_RINGS`] rings of the
//! band.
//!
//! What stays true:
//! - A pass with a focus reads and writes only within `cleanup::REACH_RINGS` quad rings
//!   of it (less than [`SEAM_RINGS`]). So a half's pass reads only nodes all of whose
//!   quads lie in that half, and the halves write disjoint quads and nodes, none on the
//!   seam: the result does not depend on which half runs first or on the thread count.
//!   The band's pass checks the same of its part (on the quads as the halves left them)
//!   and runs on the whole surface when it does not hold.
//! - Quads keep their indices (a pass only rewrites or kills quads), so the caller's
//!   snapshot still compares quad by quad.
//! - The result is not the serial pass's: the band's operators run after the halves',
//!   not in index order among them.

use super::local::{grow_rings, Local, NONE};
use super::{topo, OperationCounts};
use glam::DVec3;
use std::sync::Arc;

/// Width of the band around the seam, in quad rings: the reach of the widest search
/// (`cleanup::REACH_RINGS`) plus two, so that a half's search from outside the band reads
/// only nodes whose quads all lie in that half.
pub(crate) const SEAM_RINGS: usize = super::cleanup::REACH_RINGS + 2;

/// How far the part of the band's pass reaches beyond the band, in quad rings (on the
/// quads before the halves' passes): twice [`SEAM_RINGS`], room for the
/// `cleanup::REACH_RINGS` + 1 rings the check in [`seam_pass`] needs after the halves'
/// rotations and merges have brought some nodes closer.
const REGION_RINGS: usize = 2 * SEAM_RINGS;

/// One topology pass over `l` (see the module docs); the same contract as
/// [`topo::pass`]: returns how many operators were applied, leaves the adjacency stale
/// when that is not zero (current when it is). Needs a current adjacency.
pub(crate) fn pass(l: &mut Local, ops: &mut OperationCounts, focus: Option<&[bool]>) -> usize {
    pass_counting(l, ops, focus).0
}

/// [`pass`], also returning how many seam nodes and quads around them the halves' passes
/// changed (none: module docs; counted in tests and debug builds, else 0).
fn pass_counting(
    l: &mut Local,
    ops: &mut OperationCounts,
    focus: Option<&[bool]>,
) -> (usize, usize) {
    let trace = l.trace.clone();
    let mut tm = crate::profile::StageTimer::new(trace.as_ref(), "topo halves", l.surface);
    let n = l.pos.len();
    let mid = l.quads.len() / 2;
    // which halves each node's alive quads lie in (bit 1: first, bit 2: second)
    let mut side = vec![0u8; n];
    for (q, quad) in l.quads.iter().enumerate() {
        if l.alive[q] {
            let bit = if q < mid { 1 } else { 2 };
            for &v in quad {
                side[v as usize] |= bit;
            }
        }
    }
    let mut band: Vec<bool> = side.iter().map(|&s| s == 3).collect();
    grow_rings(l, &mut band, SEAM_RINGS);
    // the band's pass works on the quads with a node in `region` (see `seam_pass`)
    let mut region = band.clone();
    grow_rings(l, &mut region, REGION_RINGS);
    let in_focus = |v: usize| focus.is_none_or(|f| f.get(v) == Some(&true));
    // the record behind the seam check, only where the check runs (tests, debug builds)
    let seam_before = cfg!(any(test, debug_assertions)).then(|| Seam::of(l, &side));
    tm.lap("band");
    // memory: the halves hold copies of the quads and node arrays; the parent's largest
    // ones are rebuilt from them, and the adjacency and sweep data are rebuilt by the caller
    (l.start, l.adj) = (Vec::new(), Vec::new());
    (l.qn, l.colours, l.hopeless) = (Vec::new(), Vec::new(), Vec::new());
    l.sweep_ready = false;
    let nq = l.quads.len();
    let nodes = Taken::from(l);
    // nodes in no half (removed ones): kept aside
    let aside: Vec<(usize, DVec3, DVec3, f64)> = (0..n)
        .filter(|&v| side[v] == 0)
        .map(|v| (v, nodes.pos[v], nodes.nrm[v], nodes.h[v]))
        .collect();
    let lr: &Local = l;
    let focus_of = |bit: u8| {
        let (side, band) = (&side, &band);
        move |v: usize| side[v] == bit && !band[v] && in_focus(v)
    };
    let (mut a, mut b) = rayon::join(
        || Part::new(lr, &nodes, 0..mid, focus_of(1)),
        || Part::new(lr, &nodes, mid..nq, focus_of(2)),
    );
    drop(nodes);
    tm.lap("split");
    let (mut ops_a, mut ops_b) = (OperationCounts::default(), OperationCounts::default());
    let (na, nb) = rayon::join(
        || topo::pass(&mut a.local, &mut ops_a, Some(&a.focus)),
        || topo::pass(&mut b.local, &mut ops_b, Some(&b.focus)),
    );
    tm.lap("halves");
    // every quad is in one half, every node not aside in at least one
    l.quads = vec![[0; 4]; nq];
    l.alive = vec![false; nq];
    l.pos = vec![DVec3::ZERO; n];
    l.nrm = vec![DVec3::ZERO; n];
    l.h = vec![0.0; n];
    for (v, p, nr, h) in aside {
        (l.pos[v], l.nrm[v], l.h[v]) = (p, nr, h);
    }
    a.write_back(l);
    b.write_back(l);
    let touched = seam_before.map_or(0, |seam| seam.changes(l));
    debug_assert_eq!(touched, 0, "the halves changed the seam");
    for o in [ops_a, ops_b] {
        ops.doublet_collapses += o.doublet_collapses;
        ops.quad_vertex_merges += o.quad_vertex_merges;
        ops.edge_rotations += o.edge_rotations;
    }
    tm.lap("write back");
    let ns = seam_pass(l, ops, &band, &region, &in_focus);
    tm.lap("seam");
    tm.done();
    // the caller rebuilds the adjacency only after a pass that changed something; this one
    // dropped it either way
    if na + nb + ns == 0 {
        l.build_adjacency();
    }
    (na + nb + ns, touched)
}

/// The seam nodes (in quads of both halves) and the quads around them, as they were
/// before the halves' passes.
struct Seam {
    nodes: Vec<(u32, DVec3, bool)>,
    quads: Vec<(u32, [u32; 4], bool)>,
}

impl Seam {
    fn of(l: &Local, side: &[u8]) -> Seam {
        let on = |v: u32| side[v as usize] == 3;
        Seam {
            nodes: (0..l.pos.len() as u32)
                .filter(|&v| on(v))
                .map(|v| (v, l.pos[v as usize], l.removed[v as usize]))
                .collect(),
            quads: (0..l.quads.len() as u32)
                .filter(|&q| l.alive[q as usize] && l.quads[q as usize].iter().any(|&v| on(v)))
                .map(|q| (q, l.quads[q as usize], l.alive[q as usize]))
                .collect(),
        }
    }

    /// How many of these nodes and quads differ in `l` (moved, removed, rewritten or
    /// killed): zero after the halves' passes (module docs).
    fn changes(&self, l: &Local) -> usize {
        let nodes = self
            .nodes
            .iter()
            .filter(|&&(v, p, r)| l.pos[v as usize] != p || l.removed[v as usize] != r);
        let quads = self.quads.iter().filter(|&&(q, nodes, alive)| {
            l.quads[q as usize] != nodes || l.alive[q as usize] != alive
        });
        nodes.count() + quads.count()
    }
}

/// The band's pass (module docs): on the part made of the quads with a node in `region`,
/// with the focus `band` (and `in_focus`), when every node within
/// `cleanup::REACH_RINGS` + 1 rings of that focus in the part lies in `region` (so has all
/// its quads in the part); else on the whole surface.
fn seam_pass(
    l: &mut Local,
    ops: &mut OperationCounts,
    band: &[bool],
    region: &[bool],
    in_focus: &dyn Fn(usize) -> bool,
) -> usize {
    let quads: Vec<u32> = (0..l.quads.len() as u32)
        .filter(|&q| l.alive[q as usize] && l.quads[q as usize].iter().any(|&v| region[v as usize]))
        .collect();
    let taken = Taken::from(l);
    let mut part = Part::new(l, &taken, quads.iter().map(|&q| q as usize), |v| {
        band[v] && in_focus(v)
    });
    taken.put_back(l);
    let mut reach = part.focus.clone();
    grow_rings(&part.local, &mut reach, super::cleanup::REACH_RINGS + 1);
    let contained = reach
        .iter()
        .zip(&part.local.global)
        .all(|(&r, &g)| !r || region[g as usize]);
    if !contained {
        l.build_adjacency();
        let focus: Vec<bool> = (0..l.pos.len()).map(|v| band[v] && in_focus(v)).collect();
        return topo::pass(l, ops, Some(&focus));
    }
    let changed = topo::pass(&mut part.local, ops, Some(&part.focus));
    part.write_back(l);
    changed
}

/// The parent's arrays a part copies from, taken out of it while the parts are built.
struct Taken {
    quads: Vec<[u32; 4]>,
    alive: Vec<bool>,
    pos: Vec<DVec3>,
    nrm: Vec<DVec3>,
    h: Vec<f64>,
}

impl Taken {
    fn from(l: &mut Local) -> Taken {
        Taken {
            quads: std::mem::take(&mut l.quads),
            alive: std::mem::take(&mut l.alive),
            pos: std::mem::take(&mut l.pos),
            nrm: std::mem::take(&mut l.nrm),
            h: std::mem::take(&mut l.h),
        }
    }

    fn put_back(self, l: &mut Local) {
        (l.quads, l.alive) = (self.quads, self.alive);
        (l.pos, l.nrm, l.h) = (self.pos, self.nrm, self.h);
    }
}

/// Some quads of a surface as a [`Local`] of their own: nodes numbered by first use, with
/// `global` holding each node's index in the parent; `parent` each quad's index there;
/// `focus` the focus of its pass in its own numbering.
struct Part {
    local: Local,
    parent: Vec<u32>,
    focus: Vec<bool>,
}

impl Part {
    /// The quads `quads` of `l` (quads and node data from `taken`), with `focus(v)` (a
    /// node of `l`) as the focus.
    fn new(
        l: &Local,
        taken: &Taken,
        quads: impl Iterator<Item = usize>,
        focus: impl Fn(usize) -> bool,
    ) -> Part {
        let mut map = vec![NONE; l.removed.len()];
        let mut global: Vec<u32> = Vec::new();
        let mut parent = Vec::new();
        let local_quads: Vec<[u32; 4]> = quads
            .map(|q| {
                parent.push(q as u32);
                taken.quads[q].map(|v| {
                    let slot = &mut map[v as usize];
                    if *slot == NONE {
                        *slot = global.len() as u32;
                        global.push(v);
                    }
                    *slot
                })
            })
            .collect();
        let at = |g: &u32| *g as usize;
        let mut local = Local {
            surface: l.surface,
            pos: global.iter().map(|g| taken.pos[at(g)]).collect(),
            nrm: global.iter().map(|g| taken.nrm[at(g)]).collect(),
            gate_nrm: if l.gate_nrm.is_empty() {
                Vec::new()
            } else {
                global.iter().map(|g| l.gate_nrm[at(g)]).collect()
            },
            tie: l.tie,
            located_turns: l.located_turns,
            h: global.iter().map(|g| taken.h[at(g)]).collect(),
            fixed: global.iter().map(|g| l.fixed[at(g)]).collect(),
            removed: global.iter().map(|g| l.removed[at(g)]).collect(),
            tri: global.iter().map(|g| l.tri[at(g)]).collect(),
            tags: Vec::new(),
            alive: parent.iter().map(|&q| taken.alive[q as usize]).collect(),
            origin: Vec::new(),
            quads: local_quads,
            planar: l.planar,
            in_large_mesh: l.in_large_mesh,
            reference: l.reference.as_ref().map(Arc::clone),
            ref_sizes: Vec::new(),
            start: Vec::new(),
            adj: Vec::new(),
            qn: Vec::new(),
            qn_all: l.qn_all,
            hopeless: Vec::new(),
            colours: Vec::new(),
            sweep_ready: false,
            trace: None,
            global,
        };
        local.build_adjacency();
        let focus = local.global.iter().map(|&g| focus(g as usize)).collect();
        Part {
            local,
            parent,
            focus,
        }
    }

    /// Copies the part's quads and nodes back into `l` (nodes the part did not change are
    /// written back unchanged).
    fn write_back(self, l: &mut Local) {
        let p = self.local;
        for (i, &g) in p.global.iter().enumerate() {
            let g = g as usize;
            l.pos[g] = p.pos[i];
            l.nrm[g] = p.nrm[i];
            l.h[g] = p.h[i];
            l.tri[g] = p.tri[i];
            l.removed[g] = p.removed[i];
        }
        for (j, &q) in self.parent.iter().enumerate() {
            l.quads[q as usize] = p.quads[j].map(|v| p.global[v as usize]);
            l.alive[q as usize] = p.alive[j];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{Mesh, NodeTable};
    use crate::optimize::cleanup::tests::{energy, local_of, write_back_checked};
    use crate::optimize::test_util::{bits, on_threads};
    use crate::optimize::{smooth, synth, valid};
    use std::collections::HashSet;

    /// A recombined Delaunay square of about 5,000 quads after the first smoothing, with
    /// its adjacency current (the state a first topology pass starts from), its mesh and
    /// node table.
    fn smoothed_square() -> (Mesh, NodeTable, Local) {
        let quads = (1u64..20)
            .find_map(|seed| synth::pair_optimal(&synth::delaunay_square(72, 1.0, 0.3, seed)))
            .expect("an even, matchable square");
        let m = synth::to_mesh(&quads);
        let (flat, mut l) = local_of(&m);
        smooth::smooth(&mut l, 6, 0.5);
        l.build_adjacency();
        (m, flat, l)
    }

    /// The pass in halves keeps the mesh conforming, oriented and valid (every invalid quad
    /// was one at the start, as the same nodes) with the same boundary and fixed nodes,
    /// keeps the quad indices, and lowers the valence-defect energy about as much as the
    /// serial pass (within 10 %); the halves' passes leave the seam alone.
    #[test]
    fn the_pass_in_halves_keeps_the_mesh_and_matches_the_serial_pass() {
        let (mut m, flat, start) = smoothed_square();
        let invalid = |l: &Local| -> HashSet<[u32; 4]> {
            valid::invalid_quads(l)
                .into_iter()
                .map(|q| l.quads[q as usize])
                .collect()
        };
        let invalid_before = invalid(&start);
        let walls: Vec<(usize, DVec3)> = (0..start.pos.len())
            .filter(|&v| start.fixed[v])
            .map(|v| (v, start.pos[v]))
            .collect();
        let mut serial = start.clone();
        let mut ops = OperationCounts::default();
        let by_one = topo::pass(&mut serial, &mut ops, None);
        let mut halves = start.clone();
        let mut ops_h = OperationCounts::default();
        let (by_halves, touched) = pass_counting(&mut halves, &mut ops_h, None);
        assert_eq!(touched, 0, "the halves changed the seam");
        assert_eq!(
            by_halves,
            ops_h.doublet_collapses + ops_h.quad_vertex_merges + ops_h.edge_rotations
        );
        assert_eq!(halves.quads.len(), start.quads.len());
        assert!(
            invalid(&halves).is_subset(&invalid_before),
            "a quad the start did not have invalid is"
        );
        for &(v, p) in &walls {
            assert_eq!(halves.pos[v], p, "fixed node {v} moved");
        }
        let mut start = start;
        let (e0, e1, eh) = (energy(&mut start), energy(&mut serial), energy(&mut halves));
        assert!(
            by_one > 100 && e1 < e0,
            "the serial pass did little: {by_one}, {e0} -> {e1}"
        );
        assert!(
            by_halves * 10 >= by_one * 9 && eh * 10 <= e1 * 11,
            "halves: {by_halves} operators, defect energy {eh}; serial: {by_one}, {e1}"
        );
        // conforming, oriented, the boundary on the curves (the independent checker)
        write_back_checked(&mut m, flat, &halves);
    }

    /// The halves run side by side: the result is the same, bit for bit, on one thread
    /// and on three.
    #[test]
    fn the_pass_in_halves_does_not_depend_on_the_thread_count() {
        let run = |threads: usize| {
            on_threads(threads, || {
                let (_, _, mut l) = smoothed_square();
                pass(&mut l, &mut OperationCounts::default(), None);
                (l.quads, l.alive, l.removed, bits(&l.pos))
            })
        };
        assert!(run(1) == run(3), "the result depends on the thread count");
    }

    /// When its part does not hold everything the band's pass may read (here: a part of
    /// the band alone), the band's pass runs on the whole surface, with the same result as
    /// a pass focused on the band there.
    #[test]
    fn the_band_pass_runs_on_the_whole_surface_when_its_part_is_too_small() {
        let (_, _, l) = smoothed_square();
        // a band across the middle of the square
        let band: Vec<bool> = l.pos.iter().map(|p| (p.x - 0.5).abs() < 0.05).collect();
        assert!(band.iter().filter(|&&b| b).count() > 50);
        let mut whole = l.clone();
        let direct = topo::pass(&mut whole, &mut OperationCounts::default(), Some(&band));
        assert!(direct > 0);
        let via = |region: &[bool]| {
            let mut part = l.clone();
            let n = seam_pass(
                &mut part,
                &mut OperationCounts::default(),
                &band,
                region,
                &|_| true,
            );
            (n, part)
        };
        // a region no wider than the band: the whole surface
        let (n, part) = via(&band);
        assert_eq!(n, direct);
        assert!(part.quads == whole.quads && part.alive == whole.alive && part.pos == whole.pos);
        // with a region wide enough the part is used, and finds the same here
        let mut wide = band.clone();
        grow_rings(&l, &mut wide, REGION_RINGS);
        let (n, part) = via(&wide);
        assert_eq!(n, direct);
        assert!(part.quads == whole.quads && part.alive == whole.alive);
    }

    /// A pass that finds nothing to do (a structured grid) leaves the adjacency current,
    /// as the serial pass does: the caller rebuilds it only after a change.
    #[test]
    fn a_pass_that_changes_nothing_leaves_the_adjacency_current() {
        let (_, mut l) = local_of(&synth::to_mesh(&synth::quad_grid(40, 40, 1.0, 1.0)));
        let (start, adj) = (l.start.clone(), l.adj.clone());
        assert_eq!(pass(&mut l, &mut OperationCounts::default(), None), 0);
        assert!(l.start == start && l.adj == adj);
    }
}
