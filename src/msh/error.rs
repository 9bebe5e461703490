//! Typed errors of the MSH reader and writer.
//!
//! Every error renders as ONE line naming the file, the section and the position:
//! `mesh.msh: $Nodes, line 17: expected 3 coordinates, found 2` (ASCII) or
//! `mesh.msh: $Elements, byte 4711: binary data truncated: ...` (binary).

use std::fmt;

/// Where in the input an error was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// No position applies (e.g. the file could not be opened).
    None,
    /// 1-based line number in an ASCII part of the file.
    Line(usize),
    /// 0-based byte offset in a binary part of the file.
    Byte(usize),
}

/// What went wrong. Each variant is one class of bad input (or an I/O failure).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ErrorKind {
    /// Reading or writing the file failed at the operating-system level.
    #[error("{action}: {source}")]
    Io {
        /// What was attempted (`cannot read`, `cannot write`, ...).
        action: &'static str,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The input holds no byte (or only whitespace).
    #[error("file is empty")]
    Empty,
    /// The input is not an MSH file at all (a .geo script, an STL file, ...).
    #[error("{0}")]
    NotMsh(String),
    /// The `$MeshFormat` version or data size is one the crate does not handle.
    #[error("{0}")]
    Unsupported(String),
    /// The file ends in the middle of a section.
    #[error("unexpected end of file (truncated?): expected {expected}")]
    Truncated {
        /// What the reader was looking for.
        expected: String,
    },
    /// A section ends before the number of records its header announced.
    #[error(
        "section ends early: expected {expected}, found '{found}' (count in the header too large?)"
    )]
    EarlyEnd {
        /// What the reader was looking for.
        expected: String,
        /// The section end marker that was found instead.
        found: String,
    },
    /// A count announces more records than the rest of the file can hold: the file is
    /// truncated or the count is wrong.
    #[error("{what} {count} cannot fit in the {left} bytes left (file truncated, or count wrong)")]
    CountTooLarge {
        /// What is counted.
        what: String,
        /// The announced count.
        count: u64,
        /// Bytes left in the file.
        left: u64,
    },
    /// A token is not what the grammar requires at this point.
    #[error("expected {expected}, found '{found}'")]
    Unexpected {
        /// What the reader was looking for.
        expected: String,
        /// What it found (shortened).
        found: String,
    },
    /// A numeric field holds something that is not a number of the required kind.
    #[error("non-numeric field: expected {expected}, found '{found}'")]
    NotANumber {
        /// Kind of number expected (`an integer`, `a coordinate`, ...).
        expected: String,
        /// The token found (shortened).
        found: String,
    },
    /// A coordinate or parametric value is NaN or infinite.
    #[error("{what} is not finite ({found})")]
    NotFinite {
        /// Which value.
        what: String,
        /// Its text or value.
        found: String,
    },
    /// A data line has fewer fields than required.
    #[error("expected {expected} {what}, found {found}")]
    TooFewFields {
        /// Which fields.
        what: String,
        /// How many the line must hold.
        expected: usize,
        /// How many it holds.
        found: usize,
    },
    /// A data line has more fields than its record needs (the reader refuses to guess which
    /// ones to ignore).
    #[error("{what} has {extra} field(s) too many ('{found}'); refusing to guess which to ignore")]
    TooManyFields {
        /// Which record.
        what: String,
        /// How many fields are left over.
        extra: usize,
        /// The first left-over token.
        found: String,
    },
    /// The number of records found differs from the count a header announced.
    #[error("{what}: header says {declared}, found {found}")]
    CountMismatch {
        /// What is counted.
        what: String,
        /// The announced count.
        declared: u64,
        /// The count actually read.
        found: u64,
    },
    /// An element type code that Gmsh does not define (with a fixed node count).
    #[error("unknown element type code {0}")]
    UnknownElementType(i64),
    /// An element references a node tag that no `$Nodes` section defines.
    #[error("element {element} references node {node}, which is not defined in $Nodes")]
    MissingNode {
        /// The element tag.
        element: u64,
        /// The missing node tag.
        node: u64,
    },
    /// Binary data does not fit the bytes left in the file.
    #[error("binary size mismatch: {what} needs {needed} bytes, only {available} left")]
    BinarySize {
        /// What was being read.
        what: String,
        /// Bytes needed.
        needed: u64,
        /// Bytes available.
        available: u64,
    },
    /// A required section is absent or a section is not closed.
    #[error("{0}")]
    Structure(String),
    /// A value is out of the range the format allows.
    #[error("{0}")]
    Invalid(String),
}

/// An MSH read or write error: the file, the section, the position and what went wrong.
///
/// `Display` prints one line, e.g. `mesh.msh: $Nodes, line 17: expected 3 coordinates, found 2`.
#[derive(Debug)]
#[non_exhaustive]
pub struct MshError {
    /// The file name (or `<stdin>`, `<stdout>`, or the `source` given to `read_bytes`).
    pub file: String,
    /// The section (`$Nodes`, ...) where the error was found, when inside one.
    pub section: Option<String>,
    /// Line (ASCII) or byte offset (binary) of the error.
    pub location: Location,
    /// The error class.
    pub kind: ErrorKind,
}

impl MshError {
    /// An error with no section and no position.
    pub fn new(file: &str, kind: ErrorKind) -> Self {
        MshError {
            file: file.to_string(),
            section: None,
            location: Location::None,
            kind,
        }
    }

    /// An I/O error on `file`.
    pub fn io(file: &str, action: &'static str, source: std::io::Error) -> Self {
        Self::new(file, ErrorKind::Io { action, source })
    }
}

impl fmt::Display for MshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        let mut sep = ": ";
        if let Some(s) = &self.section {
            write!(f, "{sep}{s}")?;
            sep = ", ";
        }
        match self.location {
            Location::None => {}
            Location::Line(l) => {
                write!(f, "{sep}line {l}")?;
            }
            Location::Byte(b) => {
                write!(f, "{sep}byte {b}")?;
            }
        }
        // Keep the message on one line whatever the kind carries.
        let msg = self.kind.to_string().replace(['\n', '\r'], " ");
        write!(f, ": {msg}")
    }
}

impl std::error::Error for MshError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.kind {
            ErrorKind::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

/// An error inside the parser, before the file name and section are attached.
#[derive(Debug)]
pub(crate) struct Fail {
    /// Byte offset of the offending data.
    pub pos: usize,
    /// True when the offset is inside binary data (reported as a byte offset).
    pub binary: bool,
    /// What went wrong.
    pub kind: ErrorKind,
}

impl Fail {
    /// An ASCII-position failure.
    pub fn at(pos: usize, kind: ErrorKind) -> Self {
        Fail {
            pos,
            binary: false,
            kind,
        }
    }
    /// A failure in binary data (`binary`) or ASCII text.
    pub fn new(pos: usize, binary: bool, kind: ErrorKind) -> Self {
        Fail { pos, binary, kind }
    }
    /// A binary-position failure.
    pub fn bin(pos: usize, kind: ErrorKind) -> Self {
        Fail {
            pos,
            binary: true,
            kind,
        }
    }

    /// Attaches file name and section, turning the offset into a line number when ASCII.
    pub fn into_error(self, data: &[u8], file: &str, section: Option<&str>) -> MshError {
        let location = if self.binary {
            Location::Byte(self.pos)
        } else {
            let end = self.pos.min(data.len());
            Location::Line(memchr::memchr_iter(b'\n', &data[..end]).count() + 1)
        };
        MshError {
            file: file.to_string(),
            section: section.map(|s| format!("${s}")),
            location,
            kind: self.kind,
        }
    }
}

/// Parser result.
pub(crate) type PResult<T> = Result<T, Fail>;

/// Shortens a token for an error message (at most 40 characters, lossy UTF-8).
pub(crate) fn show(tok: &[u8]) -> String {
    let s = String::from_utf8_lossy(&tok[..tok.len().min(40)]).into_owned();
    if tok.len() > 40 {
        format!("{s}...")
    } else {
        s
    }
}
