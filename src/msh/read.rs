//! The section loop: finds `$Name … $EndName` sections, dispatches each to its reader by
//! format version, keeps unknown sections raw, and recognises non-MSH input.

use nom::bytes::complete::{tag, take_till, take_while1};
use nom::character::complete::{digit1, space0, space1};
use nom::sequence::{delimited, preceded};
use nom::{IResult, Parser};

use super::error::{show, ErrorKind, Fail, MshError, PResult};
use super::scan::{parse_i64, Bin, Text};
use super::tags::TagSet;
use super::{derive, v2, v4};
use crate::mesh::{
    DataKind, DataSection, Mesh, MshFormat, MshVersion, PhysicalName, RawSection, SectionPosition,
};

/// Three byte-slice fields of one line.
type Fields3<'a> = (&'a [u8], &'a [u8], &'a [u8]);

/// `version file-type data-size`, e.g. `4.1 0 8`.
fn format_line(i: &[u8]) -> IResult<&[u8], Fields3<'_>> {
    (
        preceded(space0, take_while1(|c: u8| !c.is_ascii_whitespace())),
        preceded(space1, digit1),
        preceded(space1, digit1),
    )
        .parse(i)
}

/// `dim tag "name"` of `$PhysicalNames`.
fn physical_name_line(i: &[u8]) -> IResult<&[u8], Fields3<'_>> {
    (
        preceded(space0, take_while1(|c: u8| c == b'-' || c.is_ascii_digit())),
        preceded(space1, take_while1(|c: u8| c == b'-' || c.is_ascii_digit())),
        preceded(
            space1,
            delimited(tag("\""), take_till(|c| c == b'"' || c == b'\n'), tag("\"")),
        ),
    )
        .parse(i)
}

/// Says what a non-MSH input looks like, for the error message.
fn sniff_not_msh(d: &[u8]) -> String {
    let head = &d[..d.len().min(4096)];
    let text = String::from_utf8_lossy(head);
    let trimmed = text.trim_start();
    if d.len() >= 84 {
        let n = u32::from_le_bytes([d[80], d[81], d[82], d[83]]) as u64;
        if 84 + 50 * n == d.len() as u64 {
            return "looks like a binary STL file, not a Gmsh mesh; mesh it with Gmsh first (gmsh -2) and pass the .msh".into();
        }
    }
    if trimmed.starts_with("solid") {
        return "looks like an ASCII STL file, not a Gmsh mesh; mesh it with Gmsh first (gmsh -2) and pass the .msh".into();
    }
    let geo_words = [
        "SetFactory",
        "Point(",
        "Point (",
        "Line(",
        "Curve Loop",
        "Line Loop",
        "Plane Surface",
        "Physical ",
        "Mesh.",
        "lc =",
        "Rectangle(",
        "Box(",
        "Merge ",
    ];
    if geo_words.iter().any(|w| text.contains(w)) || trimmed.starts_with("//") {
        return "looks like a Gmsh .geo script, not a mesh; run gmsh -2 first".into();
    }
    format!(
        "not an MSH file: expected $MeshFormat at the start, found '{}'",
        show(
            trimmed
                .as_bytes()
                .split(|b| b.is_ascii_whitespace())
                .next()
                .unwrap_or(b"")
        )
    )
}

/// Reads a whole MSH file held in memory.
pub(crate) fn read(d: &[u8], file: &str) -> Result<Mesh, MshError> {
    read_with_progress(d, file, &mut |_, _| {})
}

/// [`read`], calling `progress(bytes parsed, bytes in all)` with 0 first, then at each
/// section and every [`v4::TICK_LINES`] lines of an ASCII node or element section, and
/// with both equal once the mesh is read.
pub(crate) fn read_with_progress(
    d: &[u8],
    file: &str,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Mesh, MshError> {
    progress(0, d.len() as u64);
    if d.iter().all(|b| b.is_ascii_whitespace()) {
        return Err(MshError::new(file, ErrorKind::Empty));
    }
    let first_non_ws = d.iter().position(|b| !b.is_ascii_whitespace()).unwrap_or(0);
    if d[first_non_ws] != b'$' {
        return Err(MshError::new(file, ErrorKind::NotMsh(sniff_not_msh(d))));
    }
    let mut r = Reader {
        d,
        progress,
        mesh: Mesh::default(),
        format: None,
        swap: false,
        raw2: None,
        index: None,
    };
    let mut t = Text::new(d, 0);
    loop {
        t.skip_ws();
        if t.p >= d.len() {
            break;
        }
        let hpos = t.p;
        (r.progress)(hpos as u64, d.len() as u64);
        let name = match header(&mut t) {
            Ok(x) => x,
            Err(f) => return Err(f.into_error(d, file, None)),
        };
        if let Err(f) = r.section(&mut t, name, hpos) {
            return Err(f.into_error(d, file, Some(name)));
        }
    }
    let Some(format) = r.format else {
        return Err(MshError::new(
            file,
            ErrorKind::Structure("no $MeshFormat section: not an MSH file".into()),
        ));
    };
    if let Some(raw) = r.raw2.take() {
        if let Err(f) = v2::lift(raw, &mut r.mesh) {
            return Err(f.into_error(d, file, Some("Elements")));
        }
    } else if r.index.is_none() && !r.mesh.element_blocks.is_empty() {
        // $Elements came before $Nodes: check references now.
        let ix = r.mesh.node_index();
        for b in &r.mesh.element_blocks {
            let k = b.nodes_per_element().max(1);
            if let Some(i) = b.nodes.iter().position(|&v| ix.get(v).is_none()) {
                let mut e = MshError::new(
                    file,
                    ErrorKind::MissingNode {
                        element: b.tags.get(i / k).copied().unwrap_or(0),
                        node: b.nodes[i],
                    },
                );
                e.section = Some("$Elements".into());
                return Err(e);
            }
        }
    }
    if !matches!(format.version, MshVersion::V2 { .. }) {
        let added = derive::missing_entities(&mut r.mesh);
        if added > 0 && r.mesh.has_entities_section {
            r.mesh.warnings.push(format!(
                "{added} entit(y/ies) used by node or element blocks are missing from $Entities: added without physical groups"
            ));
        }
    }
    let (_, dup) = TagSet::new(r.mesh.element_blocks.iter().map(|b| b.tags.as_slice()));
    if let Some(t) = dup {
        r.mesh.warnings.push(format!(
            "element tag {t} is used by more than one element (kept as written)"
        ));
    }
    r.mesh.format = Some(format);
    (r.progress)(d.len() as u64, d.len() as u64);
    Ok(r.mesh)
}

/// Reads a `$Name` header line; returns the name (the cursor is left at the body start).
fn header<'a>(t: &mut Text<'a>) -> PResult<&'a str> {
    t.skip_ws();
    let start = t.p;
    let tok = t.word();
    if tok.is_empty() {
        return Err(Fail::at(
            start,
            ErrorKind::Truncated {
                expected: "a section header ($Name)".into(),
            },
        ));
    }
    if tok.len() < 2 || tok[0] != b'$' {
        return Err(Fail::at(
            start,
            ErrorKind::Unexpected {
                expected: "a section header like $Nodes".into(),
                found: show(tok),
            },
        ));
    }
    let name = std::str::from_utf8(&tok[1..]).map_err(|_| {
        Fail::at(
            start,
            ErrorKind::Unexpected {
                expected: "a section name".into(),
                found: show(tok),
            },
        )
    })?;
    if name.starts_with("End") {
        return Err(Fail::at(
            start,
            ErrorKind::Structure(format!("${name} without a matching opening section")),
        ));
    }
    t.end_line("section header line")?;
    Ok(name)
}

/// Two nodes with one tag make every reference to it ambiguous: refused.
fn duplicate_node(dup: Option<u64>, section_pos: usize) -> PResult<()> {
    match dup {
        None => Ok(()),
        Some(t) => Err(Fail::at(
            section_pos,
            ErrorKind::Invalid(format!("node tag {t} is defined more than once")),
        )),
    }
}

/// What an error about an MSH version the reader does not handle says after naming it:
/// the versions read, and the Gmsh command that re-saves the file in one of them.
const RESAVE: &str = "(read: 2.0, 2.1, 2.2, 4.0 ASCII, 4.1); re-save it with gmsh IN -0 -format msh41 -o OUT.msh (or -format msh22)";

struct Reader<'a, 'p> {
    d: &'a [u8],
    /// `progress(offset, length)` (see [`read_with_progress`]).
    progress: &'p mut dyn FnMut(u64, u64),
    mesh: Mesh,
    format: Option<MshFormat>,
    swap: bool,
    raw2: Option<v2::Raw2>,
    index: Option<TagSet>,
}

impl<'a> Reader<'a, '_> {
    fn section(&mut self, t: &mut Text<'a>, name: &str, hpos: usize) -> PResult<()> {
        if name == "MeshFormat" {
            if self.format.is_some() {
                return Err(Fail::at(
                    hpos,
                    ErrorKind::Structure("second $MeshFormat section".into()),
                ));
            }
            self.mesh_format(t)?;
            return t.expect_end(name);
        }
        let Some(format) = self.format else {
            return match name {
                // MSH 1 has no $MeshFormat: it opens with $NOD (nodes) or $ELM (elements)
                "NOD" | "ELM" => Err(Fail::at(
                    hpos,
                    ErrorKind::Unsupported(format!(
                        "MSH version 1 (${name} without $MeshFormat) is not supported {RESAVE}"
                    )),
                )),
                "Nodes" | "Elements" | "Entities" | "PhysicalNames" | "Periodic" => Err(Fail::at(
                    hpos,
                    ErrorKind::Structure(format!("${name} before $MeshFormat")),
                )),
                _ => self.raw(t, name, SectionPosition::BeforeFormat),
            };
        };
        let bin = format.binary;
        let v2 = matches!(format.version, MshVersion::V2 { .. });
        let v40 = format.version == MshVersion::V40;
        match name {
            "PhysicalNames" => self.physical_names(t)?,
            "Entities" if !v2 => {
                if bin {
                    let mut b = Bin::new(self.d, t.p, self.swap);
                    v4::entities_binary(&mut b, &mut self.mesh)?;
                    t.p = b.p;
                } else {
                    v4::entities_ascii(t, v40, &mut self.mesh)?;
                }
            }
            "Nodes" if !v2 => {
                if bin {
                    let mut b = Bin::new(self.d, t.p, self.swap);
                    v4::nodes_binary(&mut b, &mut self.mesh)?;
                    t.p = b.p;
                } else {
                    let len = self.d.len() as u64;
                    let progress = &mut self.progress;
                    v4::nodes_ascii(t, v40, &mut self.mesh, &mut |p| progress(p as u64, len))?;
                }
                let (set, dup) =
                    TagSet::new(self.mesh.node_blocks.iter().map(|b| b.tags.as_slice()));
                duplicate_node(dup, hpos)?;
                self.index = Some(set);
            }
            "Elements" if !v2 => {
                if bin {
                    let mut b = Bin::new(self.d, t.p, self.swap);
                    v4::elements_binary(&mut b, &mut self.mesh, self.index.as_ref())?;
                    t.p = b.p;
                } else {
                    let len = self.d.len() as u64;
                    let progress = &mut self.progress;
                    v4::elements_ascii(t, v40, &mut self.mesh, self.index.as_ref(), &mut |p| {
                        progress(p as u64, len)
                    })?;
                }
            }
            "PartitionedEntities" if !v2 && !v40 => {
                let nparts = if bin {
                    let mut b = Bin::new(self.d, t.p, self.swap);
                    let n = v4::partitioned_entities_binary(&mut b, &mut self.mesh)?;
                    t.p = b.p;
                    n
                } else {
                    v4::partitioned_entities_ascii(t, &mut self.mesh)?
                };
                self.mesh.warnings.push(format!(
                    "partitioned mesh ({nparts} partitions): partition entities are read as plain entities with their physical groups; the output is not partitioned"
                ));
            }
            "GhostElements" => {
                self.raw_body(t, name)?;
                self.mesh
                    .warnings
                    .push("$GhostElements dropped (the output is not partitioned)".into());
                return Ok(());
            }
            "Periodic" if !v2 && bin => {
                let mut b = Bin::new(self.d, t.p, self.swap);
                v4::periodic_binary(&mut b, &mut self.mesh)?;
                t.p = b.p;
            }
            "Periodic" => v4::periodic_ascii(t, &mut self.mesh)?,
            "Nodes" | "ParametricNodes" if v2 => {
                let raw = self.raw2.get_or_insert_with(Default::default);
                if name == "ParametricNodes" {
                    v2::parametric_nodes_ascii(t, raw)?;
                } else if bin {
                    v2::nodes_binary(t, self.swap, raw)?;
                } else {
                    let len = self.d.len() as u64;
                    let progress = &mut self.progress;
                    v2::nodes_ascii(t, raw, &mut |p| progress(p as u64, len))?;
                }
                duplicate_node(TagSet::new(std::iter::once(raw.node_tags())).1, hpos)?;
            }
            "Elements" => {
                let raw = self.raw2.get_or_insert_with(Default::default);
                if bin {
                    v2::elements_binary(t, self.swap, raw)?;
                } else {
                    let len = self.d.len() as u64;
                    let progress = &mut self.progress;
                    v2::elements_ascii(t, raw, &mut |p| progress(p as u64, len))?;
                }
            }
            "NodeData" | "ElementData" | "ElementNodeData" => {
                let kind = match name {
                    "NodeData" => DataKind::Node,
                    "ElementData" => DataKind::Element,
                    _ => DataKind::ElementNode,
                };
                let body = self.raw_body(t, name)?;
                self.mesh.data_sections.push(DataSection {
                    kind,
                    body: body.to_vec(),
                    encoded_binary: None,
                });
                return Ok(());
            }
            _ => return self.raw(t, name, SectionPosition::AfterMesh),
        }
        t.expect_end(name)
    }

    /// Finds the `$EndName` line of a section kept raw; returns its body.
    fn raw_body(&mut self, t: &mut Text<'a>, name: &str) -> PResult<&'a [u8]> {
        let start = t.p;
        let marker = format!("$End{name}");
        let rest = &self.d[start..];
        let mut at = None;
        if rest.starts_with(marker.as_bytes()) {
            at = Some(0);
        } else {
            let pat = format!("\n{marker}");
            let mut from = 0;
            while let Some(i) = memchr::memmem::find(&rest[from..], pat.as_bytes()) {
                let m = from + i + 1;
                let after = rest.get(m + marker.len()).copied();
                if after.is_none_or(|b| b.is_ascii_whitespace()) {
                    at = Some(m);
                    break;
                }
                from = m;
            }
        }
        let Some(m) = at else {
            return Err(Fail::at(
                start,
                ErrorKind::Truncated {
                    expected: format!("{marker} (section ${name} is not closed)"),
                },
            ));
        };
        let body = &rest[..m];
        t.p = start + m;
        t.expect_end(name)?;
        Ok(body)
    }

    fn raw(&mut self, t: &mut Text<'a>, name: &str, position: SectionPosition) -> PResult<()> {
        let body = self.raw_body(t, name)?;
        self.mesh.raw_sections.push(RawSection {
            name: name.to_string(),
            body: body.to_vec(),
            position,
        });
        Ok(())
    }

    /// `$MeshFormat`: `version file-type data-size`, then for binary the int 1 (endianness
    /// probe) and a newline.
    fn mesh_format(&mut self, t: &mut Text<'a>) -> PResult<()> {
        t.skip_ws();
        let pos = t.p;
        let line_end = memchr::memchr(b'\n', &self.d[pos..]).map_or(self.d.len(), |i| pos + i);
        let line = &self.d[pos..line_end];
        let (_, (ver, ft, ds)) = format_line(line).map_err(|_| {
            Fail::at(
                pos,
                ErrorKind::Unexpected {
                    expected: "'version file-type data-size' (e.g. 4.1 0 8)".into(),
                    found: show(line),
                },
            )
        })?;
        let version = match ver {
            b"4.1" => MshVersion::V41,
            b"4" | b"4.0" => MshVersion::V40,
            b"2" | b"2.0" => MshVersion::V2 { minor: 0 },
            b"2.1" => MshVersion::V2 { minor: 1 },
            b"2.2" => MshVersion::V2 { minor: 2 },
            _ => {
                return Err(Fail::at(
                    pos,
                    ErrorKind::Unsupported(format!(
                        "MSH version {} is not supported {RESAVE}",
                        show(ver)
                    )),
                ))
            }
        };
        let binary = match parse_i64(ft) {
            Some(0) => false,
            Some(1) => true,
            _ => {
                return Err(Fail::at(
                    pos,
                    ErrorKind::Unsupported(format!("file-type {} (must be 0 or 1)", show(ft))),
                ))
            }
        };
        if binary && version == MshVersion::V40 {
            return Err(Fail::at(
                pos,
                ErrorKind::Unsupported(
                    "MSH 4.0 binary is not supported (Gmsh itself no longer reads it); re-export the mesh as MSH 4.1 or 2.2".into(),
                ),
            ));
        }
        if binary && ds != b"8" {
            return Err(Fail::at(
                pos,
                ErrorKind::Unsupported(format!(
                    "binary data-size {} is not supported (only 8, as Gmsh writes)",
                    show(ds)
                )),
            ));
        }
        t.p = line_end;
        t.next_line();
        if binary {
            let mut b = Bin::new(self.d, t.p, false);
            let probe = b.i32("endianness probe (int 1)")?;
            self.swap = match probe {
                1 => false,
                0x0100_0000 => true,
                _ => {
                    return Err(Fail::bin(
                        t.p,
                        ErrorKind::Invalid(format!(
                            "binary endianness probe reads {probe}, expected 1"
                        )),
                    ))
                }
            };
            t.p = b.p;
        }
        self.format = Some(MshFormat { version, binary });
        Ok(())
    }

    /// `$PhysicalNames` (ASCII in every variant): `n`, then `dim tag "name"` per line.
    fn physical_names(&mut self, t: &mut Text<'a>) -> PResult<()> {
        let n = t.count("number of physical names", 6)?;
        for _ in 0..n {
            t.skip_ws();
            let pos = t.p;
            let line_end = memchr::memchr(b'\n', &self.d[pos..]).map_or(self.d.len(), |i| pos + i);
            let line = &self.d[pos..line_end];
            if line.first() == Some(&b'$') {
                return Err(Fail::at(
                    pos,
                    ErrorKind::EarlyEnd {
                        expected: "a physical name line".into(),
                        found: show(line),
                    },
                ));
            }
            let (rest, (dim, tg, name)) = physical_name_line(line).map_err(|_| {
                Fail::at(
                    pos,
                    ErrorKind::Unexpected {
                        expected: "dim tag \"name\"".into(),
                        found: show(line),
                    },
                )
            })?;
            if rest.iter().any(|b| !b.is_ascii_whitespace()) {
                return Err(Fail::at(
                    pos,
                    ErrorKind::TooManyFields {
                        what: "physical name line".into(),
                        extra: 1,
                        found: show(rest.trim_ascii()),
                    },
                ));
            }
            let num = |s: &[u8]| {
                parse_i64(s)
                    .and_then(|v| i32::try_from(v).ok())
                    .ok_or_else(|| {
                        Fail::at(
                            pos,
                            ErrorKind::NotANumber {
                                expected: "an integer".into(),
                                found: show(s),
                            },
                        )
                    })
            };
            let dim = num(dim)?;
            if !(0..=3).contains(&dim) {
                return Err(Fail::at(
                    pos,
                    ErrorKind::Invalid(format!("physical group dimension {dim} is not in 0..=3")),
                ));
            }
            self.mesh.physical_names.push(PhysicalName {
                dim,
                tag: num(tg)?,
                name: String::from_utf8_lossy(name).into_owned(),
            });
            t.p = line_end;
        }
        Ok(())
    }
}
