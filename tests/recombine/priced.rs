//! Pairs priced out of the matching (`RecombineOptions::priced_out`, what the pipeline's
//! fallback sets for quads that were not valid): the optimum avoids them when any other
//! perfect matching exists, and still takes them when none does.

use crate::recombine_util;

use blossomquad::mesh::{etype, Mesh};
use blossomquad::recombine::{check_invariants, recombine, RecombineOptions};
use recombine_util::*;

/// Every quad of `m` as its sorted node tags.
fn quads(m: &Mesh) -> Vec<[u64; 4]> {
    let mut out = Vec::new();
    for b in m
        .element_blocks
        .iter()
        .filter(|b| b.element_type == etype::QUAD4)
    {
        for i in 0..b.len() {
            let e = b.element(i);
            let mut q = [e[0], e[1], e[2], e[3]];
            q.sort_unstable();
            out.push(q);
        }
    }
    out
}

#[test]
fn a_priced_out_pair_is_avoided_when_another_matching_exists() {
    let before = grid(&Grid::default());
    // without pricing, every cell of the regular grid is one quad
    let mut plain = before.clone();
    recombine(&mut plain, &verify_opts()).expect("recombines");
    let cells = quads(&plain);
    assert_eq!(cells.len(), 16);
    // an interior cell and a corner cell priced out
    let priced = vec![cells[0], cells[5]];
    let mut m = before.clone();
    let opts = RecombineOptions {
        priced_out: priced.clone(),
        ..verify_opts()
    };
    let r = recombine(&mut m, &opts).expect("recombines");
    let s = &r.surfaces[0];
    assert_eq!(s.pairs_priced_out, 2, "both cells are pairs of the graph");
    assert_eq!(s.priced_out_used, 0);
    let out = quads(&m);
    for p in &priced {
        assert!(!out.contains(p), "the priced-out quad {p:?} is still there");
    }
    assert_eq!(count(&m, etype::TRI3), 0);
    check_invariants(&before, &m).expect("invariants");
}

#[test]
fn a_priced_out_pair_is_kept_when_no_other_matching_exists() {
    // one square cell of two triangles: its only perfect matching is the priced pair
    let before = grid(&Grid {
        nx: 1,
        ny: 1,
        ..Default::default()
    });
    let mut plain = before.clone();
    recombine(&mut plain, &verify_opts()).expect("recombines");
    let only = quads(&plain);
    assert_eq!(only.len(), 1);
    let mut m = before.clone();
    let opts = RecombineOptions {
        priced_out: only.clone(),
        ..verify_opts()
    };
    let r = recombine(&mut m, &opts).expect("recombines");
    assert_eq!(r.surfaces[0].pairs_priced_out, 1);
    assert_eq!(r.surfaces[0].priced_out_used, 1);
    assert_eq!(quads(&m), only);
    check_invariants(&before, &m).expect("invariants");
}

#[test]
fn priced_out_quads_no_pair_forms_are_ignored() {
    let before = grid(&Grid::default());
    let mut plain = before.clone();
    recombine(&mut plain, &verify_opts()).expect("recombines");
    let mut m = before.clone();
    let opts = RecombineOptions {
        // not nodes of the mesh, and four nodes that are no two adjacent triangles
        priced_out: vec![[1000, 1001, 1002, 1003], [1, 2, 3, 4]],
        ..verify_opts()
    };
    let r = recombine(&mut m, &opts).expect("recombines");
    assert_eq!(r.surfaces[0].pairs_priced_out, 0);
    assert_eq!(quads(&m), quads(&plain));
}
