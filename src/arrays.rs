//! One surface given as plain arrays (points and triangles by index), for callers that hold
//! no MSH model: numpy and meshio users through the Python package, or a Rust program.
//!
//! [`surface_mesh`] builds a [`Mesh`] of one surface entity (tag 1) whose boundary loops
//! are curve entities with line elements (so their nodes never move and parity repair can
//! split them) and whose `fixed` points are point entities; node tag = index + 1.
//! [`quads_of`] reads the result back as arrays: every input point keeps its index (a point
//! the optimizer removed stays in the array, used by no quad), new points follow.

use std::collections::HashMap;

use crate::mesh::{etype, ElementBlock, Entity, Mesh, NodeBlock};

/// Why arrays do not describe a surface.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ArrayError {
    /// A coordinate is NaN or infinite.
    #[error("point {point} has a coordinate that is not a finite number")]
    NotFinite {
        /// Index of the point.
        point: usize,
    },
    /// A triangle or fixed index is not below the number of points.
    #[error("{what} {index} refers to point {point}, but there are only {points} points")]
    OutOfRange {
        /// "triangle" or "fixed point".
        what: &'static str,
        /// Index of the triangle (or of the entry in `fixed`).
        index: usize,
        /// The bad point index.
        point: i64,
        /// Number of points.
        points: usize,
    },
    /// A triangle names the same point twice.
    #[error("triangle {index} uses point {point} twice")]
    RepeatedPoint {
        /// Index of the triangle.
        index: usize,
        /// The repeated point.
        point: usize,
    },
    /// No triangle at all.
    #[error("there are no triangles")]
    Empty,
}

/// A mesh of one surface (entity 1) from `points` and `triangles` (indices into `points`),
/// with every boundary loop a curve entity carrying line elements, and every point of
/// `fixed` a point entity (its node never moves). See the module docs.
pub fn surface_mesh(
    points: &[[f64; 3]],
    triangles: &[[i64; 3]],
    fixed: &[i64],
) -> Result<Mesh, ArrayError> {
    let n = points.len();
    if triangles.is_empty() {
        return Err(ArrayError::Empty);
    }
    if let Some(point) = points.iter().position(|p| p.iter().any(|x| !x.is_finite())) {
        return Err(ArrayError::NotFinite { point });
    }
    let check = |what: &'static str, index: usize, point: i64| {
        if point < 0 || point as u64 >= n as u64 {
            Err(ArrayError::OutOfRange {
                what,
                index,
                point,
                points: n,
            })
        } else {
            Ok(point as usize)
        }
    };
    let mut tris: Vec<[usize; 3]> = Vec::with_capacity(triangles.len());
    for (i, t) in triangles.iter().enumerate() {
        let t = [
            check("triangle", i, t[0])?,
            check("triangle", i, t[1])?,
            check("triangle", i, t[2])?,
        ];
        if t[0] == t[1] || t[0] == t[2] {
            return Err(ArrayError::RepeatedPoint {
                index: i,
                point: t[0],
            });
        }
        if t[1] == t[2] {
            return Err(ArrayError::RepeatedPoint {
                index: i,
                point: t[1],
            });
        }
        tris.push(t);
    }
    let mut fixed_ids = Vec::with_capacity(fixed.len());
    for (i, &f) in fixed.iter().enumerate() {
        fixed_ids.push(check("fixed point", i, f)?);
    }
    fixed_ids.sort_unstable();
    fixed_ids.dedup();

    // boundary edges: used by one triangle (either direction); kept in the triangle's
    // direction so each loop runs like the surface
    let mut uses: HashMap<(usize, usize), u32> = HashMap::with_capacity(tris.len() * 2);
    for t in &tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut next: HashMap<usize, Vec<usize>> = HashMap::new();
    for t in &tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if uses[&(a.min(b), a.max(b))] == 1 {
                next.entry(a).or_default().push(b);
            }
        }
    }
    for v in next.values_mut() {
        v.sort_unstable();
    }
    // walk the boundary into chains: a loop, or (at a node where several loops touch) the
    // pieces between such nodes; each chain becomes one curve
    let mut starts: Vec<usize> = next.keys().copied().collect();
    starts.sort_unstable();
    let mut curves: Vec<Vec<usize>> = Vec::new();
    for s in starts {
        while let Some(b) = next.get_mut(&s).and_then(|v| v.pop()) {
            let mut chain = vec![s, b];
            let mut at = b;
            while at != s {
                match next.get_mut(&at).and_then(|v| v.pop()) {
                    Some(c) => {
                        chain.push(c);
                        at = c;
                    }
                    None => break,
                }
            }
            curves.push(chain);
        }
    }

    let tag = |i: usize| i as u64 + 1;
    let bbox_of = |ids: &mut dyn Iterator<Item = usize>| {
        let mut b = crate::msh::EMPTY_BOX;
        for i in ids {
            crate::msh::grow_box(&mut b, &points[i]);
        }
        b
    };
    let mut mesh = Mesh {
        has_entities_section: true,
        ..Default::default()
    };
    // which entity holds each node: a fixed point, else the first curve through it, else
    // the surface
    let mut owner: Vec<(i32, i32)> = vec![(2, 1); n];
    let mut element_tag = 0u64;
    for (k, &p) in fixed_ids.iter().enumerate() {
        let ptag = k as i32 + 1;
        owner[p] = (0, ptag);
        mesh.entities[0].push(Entity {
            dim: 0,
            tag: ptag,
            bbox: bbox_of(&mut std::iter::once(p)),
            physical_tags: Vec::new(),
            bounding: Vec::new(),
        });
        element_tag += 1;
        mesh.element_blocks.push(ElementBlock {
            entity_dim: 0,
            entity_tag: ptag,
            element_type: etype::POINT,
            tags: vec![element_tag],
            nodes: vec![tag(p)],
            partitions: None,
        });
    }
    for (c, chain) in curves.iter().enumerate() {
        let ctag = c as i32 + 1;
        for &v in chain {
            if owner[v] == (2, 1) {
                owner[v] = (1, ctag);
            }
        }
        mesh.entities[1].push(Entity {
            dim: 1,
            tag: ctag,
            bbox: bbox_of(&mut chain.iter().copied()),
            physical_tags: Vec::new(),
            bounding: Vec::new(),
        });
        let mut block = ElementBlock {
            entity_dim: 1,
            entity_tag: ctag,
            element_type: etype::LINE2,
            tags: Vec::with_capacity(chain.len() - 1),
            nodes: Vec::with_capacity(2 * (chain.len() - 1)),
            partitions: None,
        };
        for w in chain.windows(2) {
            element_tag += 1;
            block.tags.push(element_tag);
            block.nodes.extend([tag(w[0]), tag(w[1])]);
        }
        mesh.element_blocks.push(block);
    }
    mesh.entities[2].push(Entity {
        dim: 2,
        tag: 1,
        bbox: bbox_of(&mut (0..n)),
        physical_tags: Vec::new(),
        bounding: (1..=curves.len() as i32).collect(),
    });
    let mut block = ElementBlock {
        entity_dim: 2,
        entity_tag: 1,
        element_type: etype::TRI3,
        tags: Vec::with_capacity(tris.len()),
        nodes: Vec::with_capacity(3 * tris.len()),
        partitions: None,
    };
    for t in &tris {
        element_tag += 1;
        block.tags.push(element_tag);
        block.nodes.extend(t.map(tag));
    }
    mesh.element_blocks.push(block);
    // node blocks by owning entity, in index order within each
    let mut blocks: std::collections::BTreeMap<(i32, i32), NodeBlock> = Default::default();
    for (i, &(dim, etag)) in owner.iter().enumerate() {
        let b = blocks.entry((dim, etag)).or_insert_with(|| NodeBlock {
            entity_dim: dim,
            entity_tag: etag,
            tags: Vec::new(),
            coords: Vec::new(),
            params: None,
        });
        b.tags.push(tag(i));
        b.coords.push(points[i]);
    }
    mesh.node_blocks = blocks.into_values().collect();
    Ok(mesh)
}

/// The quads of `mesh` (a result of [`surface_mesh`] on `input` points after
/// [`quadrangulate`](crate::quadrangulate) with [`keep_tags`](crate::Options::keep_tags):
/// the points are found by tag) as arrays: points by index and quads of point
/// indices. Input points keep their index (at their new position; a point the optimizer
/// removed keeps its input position and no quad uses it); the points the run added follow,
/// in tag order.
pub fn quads_of(mesh: &Mesh, input: &[[f64; 3]]) -> (Vec<[f64; 3]>, Vec<[u64; 4]>) {
    let n = input.len() as u64;
    let mut points = input.to_vec();
    let mut added: Vec<(u64, [f64; 3])> = Vec::new();
    for b in &mesh.node_blocks {
        for (&t, c) in b.tags.iter().zip(&b.coords) {
            if (1..=n).contains(&t) {
                points[t as usize - 1] = *c;
            } else {
                added.push((t, *c));
            }
        }
    }
    added.sort_unstable_by_key(|a| a.0);
    let index = |t: u64| -> u64 {
        if (1..=n).contains(&t) {
            t - 1
        } else {
            // every quad node is a node of the mesh: present in `added`
            n + added.partition_point(|a| a.0 < t) as u64
        }
    };
    let mut quads = Vec::new();
    for b in mesh
        .element_blocks
        .iter()
        .filter(|b| b.entity_dim == 2 && b.element_type == etype::QUAD4)
    {
        for i in 0..b.len() {
            let e = b.element(i);
            quads.push([index(e[0]), index(e[1]), index(e[2]), index(e[3])]);
        }
    }
    points.extend(added.iter().map(|a| a.1));
    (points, quads)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keep_tags() -> crate::Options {
        crate::Options {
            keep_tags: true,
            ..Default::default()
        }
    }

    /// A 3 x 3 grid of squares split into 18 triangles, with a square hole in the middle
    /// cell removed (16 triangles): two boundary loops.
    fn grid_with_hole() -> (Vec<[f64; 3]>, Vec<[i64; 3]>) {
        let mut pts = Vec::new();
        for j in 0..4 {
            for i in 0..4 {
                pts.push([i as f64, j as f64, 0.0]);
            }
        }
        let mut tris = Vec::new();
        for j in 0..3i64 {
            for i in 0..3i64 {
                if (i, j) == (1, 1) {
                    continue;
                }
                let a = j * 4 + i;
                tris.push([a, a + 1, a + 5]);
                tris.push([a, a + 5, a + 4]);
            }
        }
        (pts, tris)
    }

    #[test]
    fn boundary_loops_become_curves_and_the_result_reads_back() {
        let (pts, tris) = grid_with_hole();
        let mut mesh = surface_mesh(&pts, &tris, &[]).expect("mesh");
        assert_eq!(mesh.entities[1].len(), 2, "outer loop and hole");
        let lines: usize = mesh.count_elements(etype::LINE2);
        assert_eq!(lines, 12 + 4, "every boundary edge is a line element");
        crate::quadrangulate(&mut mesh, &keep_tags()).expect("quads");
        let (p, q) = quads_of(&mesh, &pts);
        assert!(p.len() >= pts.len());
        assert_eq!(&p[..4], &pts[..4], "boundary points do not move");
        assert!(!q.is_empty());
        assert!(q.iter().flatten().all(|&v| (v as usize) < p.len()));
    }

    #[test]
    fn an_odd_surface_gets_a_parity_split_point_appended() {
        let (pts, mut tris) = grid_with_hole();
        tris.pop();
        let mut mesh = surface_mesh(&pts, &tris, &[5]).expect("mesh");
        assert_eq!(mesh.entities[0].len(), 1, "the fixed point");
        let input = mesh.clone();
        crate::quadrangulate(&mut mesh, &keep_tags()).expect("quads");
        assert!(crate::validity::invalid_quads(&input, &mesh).is_empty());
        let (p, q) = quads_of(&mesh, &pts);
        assert!(p.len() > pts.len(), "a split point is appended");
        assert!(p.iter().all(|c| c.iter().all(|x| x.is_finite())));
        assert_eq!(p[5], pts[5], "the fixed point stays");
        assert!(q.iter().flatten().any(|&v| v as usize >= pts.len()));
    }

    #[test]
    fn bad_arrays_are_refused_in_words() {
        let (pts, tris) = grid_with_hole();
        let mut bad = tris.clone();
        bad[3][1] = 99;
        let e = surface_mesh(&pts, &bad, &[]).expect_err("out of range");
        assert_eq!(
            e.to_string(),
            "triangle 3 refers to point 99, but there are only 16 points"
        );
        let mut nan = pts.clone();
        nan[5][2] = f64::NAN;
        assert!(matches!(
            surface_mesh(&nan, &tris, &[]),
            Err(ArrayError::NotFinite { point: 5 })
        ));
        bad = tris.clone();
        bad[0] = [2, 2, 7];
        assert!(matches!(
            surface_mesh(&pts, &bad, &[]),
            Err(ArrayError::RepeatedPoint { index: 0, point: 2 })
        ));
        assert!(matches!(
            surface_mesh(&pts, &tris, &[-1]),
            Err(ArrayError::OutOfRange { .. })
        ));
        assert_eq!(surface_mesh(&pts, &[], &[]), Err(ArrayError::Empty));
    }
}
