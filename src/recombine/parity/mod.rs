//! Parity repair (paper eq. 5–6 and section 7 step 1), step 3 of the recombination (see
//! [`super`]).
//!
//! **Parity** (eq. 5–6). Every region needs an even number of triangles. Splitting a wall
//! segment at its midpoint splits the adjacent triangle on each side, so it flips the
//! parity of every region that has an odd number of triangles on that segment: a segment
//! on the outer boundary flips its one region, an interface between two surfaces (or two
//! regions cut by an embedded curve) flips both, a seam or a dangling embedded curve with
//! the same region on both sides flips nothing. Segments are grouped by (curve, flipped
//! regions) — the curve from the line element, or from node classification, or none for
//! files without curve data — and the choice of groups is a GF(2) system over the
//! group–region incidence (`parity::solve_groups`). Groups flipping one or two regions
//! are the edges of a region graph (a one-region group joins its region to a "ground"
//! node). Inside one connected component of that graph any even set of odd regions can
//! be fixed along paths, and any set when the component holds the ground, so the only
//! constraint left is one parity bit per ungrounded component; groups flipping three or
//! more regions (curves shared by 3+ surfaces) change those bits, and a small GF(2)
//! system (rows: ungrounded components, columns: those groups, cheapest first) solved by
//! Gaussian elimination picks the ones to split, so of two such curves that fix the same
//! components the cheaper is split (the inner circle where a coarse pipe's legs meet,
//! rather than the outer one, when the inner is the shorter wall of an odd annulus face). The system is solvable exactly when some set of
//! curve node-count changes makes every region even, and `--parity error` reports the
//! same plan. The rest is a T-join with T = the odd regions, found with the fewest
//! splits (each group costs one split, more on a strip it would spoil, below): a
//! minimum-cost perfect matching ([`crate::matching`]) pairs the odd regions with each
//! other (cost = shortest-path length in the region graph) or with the ground (each odd
//! region has a ground twin at its distance to the nearest outer-boundary group; twins pair
//! with each other at cost 0), and the groups along each pair's shortest path are split
//! (a group used twice cancels). Two odd surfaces sharing a curve are fixed by one split
//! of that curve. (Beyond 1500 odd regions, or when no pairing exists, a spanning-forest
//! T-join is used instead.)
//! A segment of a periodic curve is split together with its images on every curve linked
//! to it (through chains of `$Periodic` curve links), at their chord midpoints (which
//! correspond through an affine transform), and the new node pairs are added to the curve
//! links and to the surface links that pair the segments' ends; the group flips the
//! regions of all those segments. When the segment's curve is not known (MSH 2.2 without
//! line elements, where `$Periodic` has surface links only), a segment that is an edge
//! of a periodic slave or master surface is split with its images through the surface
//! links (which list the boundary nodes too) the same way; a segment whose image is not
//! an edge there is not split. A segment bordered by a quad (of another surface:
//! `Layers`/`Recombine` faces) is split through the quad chord that starts there: every
//! edge reached by stepping to the opposite edge of each quad is split at its midpoint,
//! each quad of the chord becomes two quads, and the triangles at the chord's far end
//! are split like any parity split (chords that would cross a quad both ways or touch a
//! periodic curve are not used). Chords are tried only when the plain splits cannot fix
//! every region and the odd surface has no quads of its own (a mixed surface is
//! retriangulated instead, below). In each chosen group the longest segment is
//! split — preferring segments whose triangles are not *ears* nor next to one (an ear has
//! two wall edges: a split
//! half would have the other half as its only neighbour, forcing a 180° "quad"). On a
//! *strip* (a region whose every triangle has a wall edge, like the narrow face between
//! the two big faces of a thin plate) the place decides the quads, since the strip's
//! triangles form a path or a band with one or two perfect matchings: a strip flipped by
//! two chosen groups gets their segments on either side of one interior edge, and that
//! edge is flipped after the splits to join the two new nodes, adding a column of
//! alternating triangles that pairs into sound quads whichever way the strip is matched
//! (`parity::column`); an odd path or closed band flipped by one group gets the segment
//! (of any group flipping the same regions) whose split gives the strip's forced matching
//! (on a band, the one of its two alternations that keeps the split's halves apart) the
//! best worst quad, and the T-join counts a group whose best split there still leaves a
//! quad that is not valid as 2.5 splits (1.5 when under η 0.2), and a group whose
//! segments on an odd band all lie on the band's longer wall (more segments) as 1.5
//! splits, so it takes another curve when one is as near. Each segment is split at its
//! chord midpoint (so planar areas are unchanged), parametric coordinates
//! interpolated; the new node gets tag `max + 1` and is classified on the curve (appended
//! to its node block), or on the first flipped surface when no curve is known. Every
//! triangle and 2-node line element holding the segment is split in two: the first piece
//! keeps the element tag, the second gets a fresh tag above the maximum. With
//! [`super::ParityMode::Error`] nothing is changed and [`RecombineError::OddParity`] lists the odd
//! surfaces, the curves to fix and how to fix them in the .geo.
//!
//! *Strip end turns* (`turn`) run before the plan: they add three triangles at each end of
//! a narrow face that turns, so they keep every region's parity (see that module).
//!
//! *Mixed surfaces.* Quads already present are kept and only the triangles recombined.
//! When a surface's triangles are enclosed by quads so that they cannot be made even (no
//! splittable segment) or have no perfect matching — typically the isolated triangles a
//! partial recombination leaves — that surface's quads are split into two triangles each
//! (shorter diagonal, orientation kept, the first half keeps the quad's tag) and the whole
//! surface is recombined; [`super::RecombineReport::retriangulated`] and the log say so.

use std::collections::HashMap;

use glam::DVec3;

use super::topology::{edge_key, NONE};
use super::{ParitySplit, RecombineError, SurfaceWork};
use crate::mesh::{etype, Mesh, NodeBlock, NodeTable};

mod apply;
mod column;
mod periodic;
mod plan;
mod tjoin;
mod turn;

pub(crate) use apply::{add_node, apply};
pub(crate) use turn::{apply_turns, turns};
pub(crate) use plan::plan;
pub(crate) use tjoin::solve_groups;

use column::*;
use periodic::*;
use tjoin::*;

/// One odd triangle region.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OddRegion {
    /// Surface entity tag.
    pub surface: i32,
    /// Index of the region inside the surface (regions are the connected parts of the
    /// surface's triangles separated by curves), and the number of regions.
    pub region: (usize, usize),
    /// Number of triangles in the region.
    pub triangles: usize,
}

/// A boundary segment chosen for splitting.
#[derive(Debug, Clone)]
pub(crate) struct Choice {
    /// Global ids of the segment's nodes.
    pub a: u32,
    /// See `a`.
    pub b: u32,
    /// Curve the segment lies on, when known.
    pub curve: Option<i32>,
    /// Surfaces whose parity the split flips.
    pub surfaces: Vec<i32>,
    /// Segments split together with `a`–`b`: its images on periodic curves, or the other
    /// edges of a quad chord (see [`quad_chords`]), with their curve when known.
    pub with: Vec<(u32, u32, Option<i32>)>,
}

/// Result of the parity analysis.
pub(crate) struct Plan {
    /// Odd regions.
    pub odd: Vec<OddRegion>,
    /// Segments to split so that every region becomes even.
    pub choices: Vec<Choice>,
    /// Pairs of `choices` split across a strip, with the edge flipped after the splits.
    pub columns: Vec<Column>,
    /// Odd regions the plan cannot fix (no splittable segment connects them to a fix).
    pub unsolved: Vec<OddRegion>,
    /// For each of `unsolved`: true when no split at all flips it (as opposed to splits
    /// that exist but always flip an even number of odd regions).
    pub isolated: Vec<bool>,
}

pub(crate) struct Group {
    curve: Option<i32>,
    /// Regions flipped, sorted.
    sig: Vec<u32>,
    /// (not avoided, no ear beside it, length, a, b) of the best segment so far.
    best: (bool, bool, f64, u32, u32),
    /// Segments split together with the best one (its periodic images, or the rest of a
    /// quad chord), with their curve when known.
    with: Vec<(u32, u32, Option<i32>)>,
}

/// " (region 1 of 3, separated by embedded curves)" when `o`'s surface has several regions,
/// else nothing.
pub(crate) fn region_note(o: &OddRegion) -> String {
    if o.region.1 > 1 {
        format!(
            " (region {} of {}, separated by embedded curves)",
            o.region.0 + 1,
            o.region.1
        )
    } else {
        String::new()
    }
}

/// "surface 2 (region 1 of 3, separated by embedded curves) has 117 triangles (odd)".
fn describe(o: &OddRegion) -> String {
    format!(
        "surface {}{} has {} triangles (odd)",
        o.surface,
        region_note(o),
        o.triangles
    )
}

/// Why the odd regions `unsolved` cannot be made even, in plain words.
pub(crate) fn unsolvable_message(unsolved: &[OddRegion], isolated: &[bool]) -> String {
    let mut lines = Vec::new();
    let mut rest = Vec::new();
    for (o, &iso) in unsolved.iter().zip(isolated) {
        if iso {
            lines.push(format!(
                "{}; no segment around it can be split: every curve around it is closed on itself \
                 (a seam with the surface on both sides), periodic with images that cancel the \
                 split, or bordered by quads whose strip cannot be split",
                describe(o)
            ));
        } else {
            rest.push(describe(o));
        }
    }
    if !rest.is_empty() {
        lines.push(format!(
            "{}; every split of the curves around {} changes an even number of odd surfaces, \
             so an odd one always remains",
            rest.join(", "),
            if rest.len() == 1 { "it" } else { "them" }
        ));
    }
    format!(
        "cannot make every surface even by splitting boundary segments: {}; remesh with a \
         different size, or with an odd number of nodes on one of its curves",
        lines.join("; ")
    )
}

/// [`RecombineError::ParityUnsolvable`] for a plan with unsolved regions.
pub(crate) fn unsolvable_error(plan: &Plan) -> RecombineError {
    RecombineError::ParityUnsolvable {
        regions: plan.unsolved.clone(),
        message: unsolvable_message(&plan.unsolved, &plan.isolated),
    }
}

/// [`RecombineError::ParityUnsolvable`] when regions are still odd after the splits (a bug:
/// the plan said they would be even).
pub(crate) fn still_odd_error(odd: &[OddRegion]) -> RecombineError {
    let list: Vec<String> = odd.iter().map(describe).collect();
    RecombineError::ParityUnsolvable {
        regions: odd.to_vec(),
        message: format!(
            "parity repair split boundary segments but {} still odd (an internal error; \
             please report it with the input mesh)",
            if list.len() == 1 {
                format!("{} is", list[0])
            } else {
                format!("{} are", list.join(", "))
            }
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unsolvable_message_is_plain_words() {
        let o = OddRegion {
            surface: 2,
            region: (0, 1),
            triangles: 117,
        };
        let p = OddRegion {
            surface: 5,
            region: (1, 3),
            triangles: 9,
        };
        let msg = unsolvable_message(&[o.clone(), p], &[true, false]);
        assert!(msg.contains("surface 2 has 117 triangles (odd)"), "{msg}");
        assert!(msg.contains("surface 5 (region 2 of 3"), "{msg}");
        assert!(!msg.contains('{') && !msg.contains("OddRegion"), "{msg}");
        let e = still_odd_error(&[o]).to_string();
        assert!(!e.contains('{') && e.contains("surface 2 has 117"), "{e}");
    }

    #[test]
    fn the_t_join_takes_the_cheaper_path_and_the_fewest_splits_at_equal_costs() {
        // odd regions 0 and 1, joined directly by group 0 and through region 2 by groups 1
        // and 2; region 3 is the ground (no group reaches it)
        let adj: Vec<Vec<(u32, usize)>> = vec![
            vec![(1, 0), (2, 1)],
            vec![(0, 0), (2, 2)],
            vec![(0, 1), (1, 2)],
            vec![],
        ];
        let sorted = |mut v: Vec<usize>| {
            v.sort_unstable();
            v
        };
        let equal = min_tjoin(&adj, &[0, 1], 3, &[2, 2, 2]).map(sorted);
        assert_eq!(equal, Some(vec![0]));
        let dear = min_tjoin(&adj, &[0, 1], 3, &[5, 2, 2]).map(sorted);
        assert_eq!(dear, Some(vec![1, 2]));
    }

    #[test]
    fn of_curves_shared_by_three_surfaces_that_fix_the_same_parities_the_cheaper_is_split() {
        // a pipe's two legs: odd end caps 0 and 3 (annulus bands), the first leg's outer and
        // inner walls 1 and 2, the second leg's 4 and 5 (reaching the ground, an open end);
        // each cap's outer circle is its longer wall, which costs one more
        let group = |sig: &[u32]| Group {
            curve: None,
            sig: sig.to_vec(),
            best: (true, true, 1.0, 0, 1),
            with: Vec::new(),
        };
        let list = vec![
            group(&[0, 1]),    // cap 0's outer circle
            group(&[0, 2]),    // cap 0's inner circle
            group(&[1, 3, 4]), // the outer circle where the legs meet cap 3
            group(&[2, 3, 5]), // the inner one
            group(&[4]),
            group(&[5]),
        ];
        let odd = [true, false, false, true, false, false];
        let sorted = |mut v: Vec<usize>| {
            v.sort_unstable();
            v
        };
        let (chosen, unsolved) = solve_groups(&list, &odd, &[3, 2, 3, 2, 2, 2]);
        assert!(unsolved.is_empty());
        assert_eq!(sorted(chosen), vec![1, 3, 5]);
        // at equal costs the first in the list
        let (chosen, _) = solve_groups(&list, &odd, &[2; 6]);
        assert_eq!(sorted(chosen), vec![0, 2, 4]);
    }

    #[test]
    fn gf2_solve_handles_three_way_columns() {
        // rows: 3 components; columns flip {0,1,2} and {0,1}: only their sum flips {2}
        let cols = vec![vec![0, 1, 2], vec![0, 1]];
        let flips = |x: &[bool]| {
            let mut got = [false; 3];
            for (j, c) in cols.iter().enumerate() {
                if x[j] {
                    for &r in c {
                        got[r as usize] ^= true;
                    }
                }
            }
            got
        };
        assert_eq!(
            flips(&gf2_solve(3, &cols, &[false, false, true])),
            [false, false, true]
        );
        assert_eq!(
            flips(&gf2_solve(3, &cols, &[true, true, false])),
            [true, true, false]
        );
        // {0} alone is out of reach: whatever is returned leaves some row wrong
        assert_ne!(
            flips(&gf2_solve(3, &cols, &[true, false, false])),
            [true, false, false]
        );
    }
}
