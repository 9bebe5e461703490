//! A printable overview of a mesh, for the CLI's `info` command.

use std::fmt;

use crate::mesh::{etype, Mesh, MshFormat};

/// Element counts of one surface entity.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SurfaceSummary {
    /// Surface entity tag.
    pub tag: i32,
    /// Physical tags of the surface.
    pub physical_tags: Vec<i32>,
    /// `(element type code, count)`, sorted by type code.
    pub counts: Vec<(u32, usize)>,
    /// Number of triangles (3- or 6-node).
    pub triangles: usize,
}

impl SurfaceSummary {
    /// True when the triangle count is even (a perfect matching of the triangles can exist).
    pub fn triangles_even(&self) -> bool {
        self.triangles.is_multiple_of(2)
    }
}

/// One physical group.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GroupSummary {
    /// Dimension of the group.
    pub dim: i32,
    /// Physical tag.
    pub tag: i32,
    /// Name from `$PhysicalNames`, if any.
    pub name: Option<String>,
    /// Number of entities in the group.
    pub entities: usize,
}

/// Overview of a mesh: format, entity counts, per-surface element counts, physical groups.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSummary {
    /// Format the mesh was read from.
    pub format: Option<MshFormat>,
    /// Number of entities of dimension 0, 1, 2, 3.
    pub entities_per_dim: [usize; 4],
    /// Total node count.
    pub nodes: usize,
    /// Total element count.
    pub elements: usize,
    /// Per surface entity (dimension 2), sorted by tag.
    pub surfaces: Vec<SurfaceSummary>,
    /// Physical groups, sorted by (dim, tag).
    pub groups: Vec<GroupSummary>,
}

/// Short name of a Gmsh element type code.
pub(crate) fn type_name(t: u32) -> String {
    match t {
        1 => "line2".into(),
        2 => "tri3".into(),
        3 => "quad4".into(),
        4 => "tet4".into(),
        5 => "hex8".into(),
        6 => "prism6".into(),
        7 => "pyramid5".into(),
        8 => "line3".into(),
        9 => "tri6".into(),
        10 => "quad9".into(),
        11 => "tet10".into(),
        15 => "point".into(),
        16 => "quad8".into(),
        _ => format!("type{t}"),
    }
}

/// Summarises `mesh` (see [`MeshSummary`]).
pub fn summary(mesh: &Mesh) -> MeshSummary {
    let mut surfaces: Vec<SurfaceSummary> = mesh.entities[2]
        .iter()
        .map(|e| SurfaceSummary {
            tag: e.tag,
            physical_tags: e.physical_tags.clone(),
            counts: Vec::new(),
            triangles: 0,
        })
        .collect();
    for b in mesh.element_blocks.iter().filter(|b| b.entity_dim == 2) {
        let i = match surfaces.iter().position(|s| s.tag == b.entity_tag) {
            Some(i) => i,
            None => {
                surfaces.push(SurfaceSummary {
                    tag: b.entity_tag,
                    physical_tags: Vec::new(),
                    counts: Vec::new(),
                    triangles: 0,
                });
                surfaces.len() - 1
            }
        };
        let s = &mut surfaces[i];
        match s.counts.iter_mut().find(|c| c.0 == b.element_type) {
            Some(c) => c.1 += b.len(),
            None => s.counts.push((b.element_type, b.len())),
        }
        if matches!(b.element_type, etype::TRI3 | etype::TRI6) {
            s.triangles += b.len();
        }
    }
    for s in surfaces.iter_mut() {
        s.counts.sort_unstable();
    }
    surfaces.sort_by_key(|s| s.tag);

    let mut groups: Vec<GroupSummary> = Vec::new();
    for e in mesh.entities.iter().flatten() {
        for &p in &e.physical_tags {
            match groups.iter_mut().find(|g| g.dim == e.dim && g.tag == p) {
                Some(g) => g.entities += 1,
                None => groups.push(GroupSummary {
                    dim: e.dim,
                    tag: p,
                    name: mesh.physical_name(e.dim, p).map(str::to_string),
                    entities: 1,
                }),
            }
        }
    }
    for n in &mesh.physical_names {
        if !groups.iter().any(|g| g.dim == n.dim && g.tag == n.tag) {
            groups.push(GroupSummary {
                dim: n.dim,
                tag: n.tag,
                name: Some(n.name.clone()),
                entities: 0,
            });
        }
    }
    groups.sort_by_key(|g| (g.dim, g.tag));

    MeshSummary {
        format: mesh.format,
        entities_per_dim: [0, 1, 2, 3].map(|d| mesh.entities[d].len()),
        nodes: mesh.node_count(),
        elements: mesh.element_count(),
        surfaces,
        groups,
    }
}

impl fmt::Display for MeshSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.format {
            Some(fm) => writeln!(f, "format: {fm}")?,
            None => writeln!(f, "format: (built in memory)")?,
        }
        let e = self.entities_per_dim;
        writeln!(
            f,
            "entities: {} points, {} curves, {} surfaces, {} volumes",
            e[0], e[1], e[2], e[3]
        )?;
        writeln!(f, "nodes: {}, elements: {}", self.nodes, self.elements)?;
        for s in &self.surfaces {
            let counts: Vec<String> = s
                .counts
                .iter()
                .map(|(t, n)| format!("{n} {}", type_name(*t)))
                .collect();
            let counts = if counts.is_empty() {
                "no elements".to_string()
            } else {
                counts.join(", ")
            };
            let parity = if s.triangles_even() { "even" } else { "odd" };
            writeln!(
                f,
                "surface {}: {counts}; triangle count {} is {parity}",
                s.tag, s.triangles
            )?;
        }
        if self.groups.is_empty() {
            writeln!(f, "physical groups: none")?;
        }
        for g in &self.groups {
            let name = g
                .name
                .as_deref()
                .map(|n| format!(" \"{n}\""))
                .unwrap_or_default();
            writeln!(
                f,
                "physical group (dim {}, tag {}){name}: {} entit{}",
                g.dim,
                g.tag,
                g.entities,
                if g.entities == 1 { "y" } else { "ies" }
            )?;
        }
        Ok(())
    }
}
