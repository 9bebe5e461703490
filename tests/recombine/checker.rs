//! The invariant check (`check_invariants`) is what every recombination test relies on, so
//! it must reject each kind of broken output: a triangle left, a hole, an edge shared by
//! three faces, a flipped quad, a lost or renamed physical group, a moved curve node, a lost
//! curve segment. Each case tampers with a correct recombination of a jittered grid.

use crate::recombine_util;

use blossomquad::mesh::{etype, ElementBlock, Mesh};
use blossomquad::recombine::{check_invariants, recombine, InvariantViolation};
use recombine_util::*;

/// A jittered 6 × 6 grid (72 triangles) and its verified recombination.
fn recombined() -> (Mesh, Mesh) {
    let before = grid(&Grid {
        nx: 6,
        ny: 6,
        jitter: 0.4,
        seed: 5,
        ..Grid::default()
    });
    let mut after = before.clone();
    recombine(&mut after, &verify_opts()).expect("recombination");
    check_invariants(&before, &after).expect("untampered output passes");
    (before, after)
}

fn quad_block(m: &mut Mesh) -> &mut ElementBlock {
    m.element_blocks
        .iter_mut()
        .find(|b| b.element_type == etype::QUAD4 && b.entity_dim == 2 && b.entity_tag == 1)
        .expect("a quad block on surface 1")
}

/// `tamper` applied to a correct output must be reported with a message containing `what`;
/// returns the violation.
fn rejected(what: &str, tamper: impl FnOnce(&mut Mesh)) -> InvariantViolation {
    let (before, mut after) = recombined();
    tamper(&mut after);
    match check_invariants(&before, &after) {
        Ok(()) => panic!("tampered output accepted (expected: {what})"),
        Err(e) => {
            let text = e.to_string();
            assert!(text.contains(what), "expected `{what}`, got `{text}`");
            e
        }
    }
}

#[test]
fn triangle_left_is_rejected() {
    let e = rejected("still has 2 triangles", |m| {
        let q = quad_block(m);
        let n: Vec<u64> = q.nodes.drain(..4).collect();
        let t = q.tags.remove(0);
        let mut tri = q.clone();
        tri.element_type = etype::TRI3;
        tri.tags = vec![t, 100_000];
        tri.nodes = vec![n[0], n[1], n[2], n[0], n[2], n[3]];
        tri.partitions = None;
        m.element_blocks.push(tri);
    });
    assert!(
        matches!(
            e,
            InvariantViolation::TrianglesLeft {
                surface: 1,
                count: 2
            }
        ),
        "{e:?}"
    );
}

#[test]
fn missing_quad_is_rejected() {
    rejected("surface 1", |m| {
        let q = quad_block(m);
        let k = q.tags.len() / 2;
        q.tags.remove(k);
        q.nodes.drain(4 * k..4 * k + 4);
    });
}

#[test]
fn duplicated_quad_is_rejected() {
    rejected("shared by 3 faces", |m| {
        let q = quad_block(m);
        let k = q.tags.len() / 2;
        let dup: Vec<u64> = q.nodes[4 * k..4 * k + 4].to_vec();
        q.nodes.extend(dup);
        q.tags.push(100_000);
    });
}

#[test]
fn flipped_quad_is_rejected() {
    rejected("against the orientation", |m| {
        let q = quad_block(m);
        q.nodes[..4].reverse();
    });
}

#[test]
fn lost_physical_group_is_rejected() {
    rejected("physical groups", |m| {
        let s = m.entities[2]
            .iter_mut()
            .find(|e| e.tag == 1)
            .expect("surface 1");
        assert_eq!(s.physical_tags, vec![10]);
        s.physical_tags.clear();
    });
}

#[test]
fn renamed_physical_group_is_rejected() {
    rejected("physical names changed", |m| {
        m.physical_names[0].name = "slab".into();
    });
}

#[test]
fn moved_curve_node_is_rejected() {
    rejected("moved from", |m| {
        let b = m
            .node_blocks
            .iter_mut()
            .find(|b| b.entity_dim == 1 && !b.coords.is_empty())
            .expect("a curve node block");
        b.coords[0][1] += 0.01;
    });
}

#[test]
fn lost_curve_segment_is_rejected() {
    rejected("line elements", |m| {
        let l = m
            .element_blocks
            .iter_mut()
            .find(|b| b.element_type == etype::LINE2 && b.len() > 1)
            .expect("a line block");
        l.tags.pop();
        l.nodes.truncate(l.nodes.len() - 2);
    });
}
