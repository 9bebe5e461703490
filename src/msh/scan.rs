//! Low-level cursors over the input bytes: [`Text`] for ASCII tokens (whitespace separated,
//! line aware where a record must sit on one line) and [`Bin`] for packed binary data.
//!
//! Neither allocates per token: tokens are sub-slices of the input, numbers are parsed in
//! place. Errors carry the byte offset; the caller turns it into a line number only when an
//! error is actually reported.

use super::error::{show, ErrorKind, Fail, PResult};

/// True for the bytes that separate tokens on a line (newline excluded).
#[inline]
fn is_inline_ws(b: u8) -> bool {
    b == b' ' || b == b'\t' || b == b'\r' || b == 0x0b || b == 0x0c
}

/// ASCII token cursor.
pub(crate) struct Text<'a> {
    /// The whole input.
    pub d: &'a [u8],
    /// Current offset.
    pub p: usize,
}

impl<'a> Text<'a> {
    /// A cursor at offset `p` of `d`.
    pub fn new(d: &'a [u8], p: usize) -> Self {
        Text { d, p }
    }

    /// Skips all whitespace, newlines included.
    #[inline]
    pub fn skip_ws(&mut self) {
        while let Some(&b) = self.d.get(self.p) {
            if b == b'\n' || is_inline_ws(b) {
                self.p += 1;
            } else {
                break;
            }
        }
    }

    /// Skips spaces, tabs and carriage returns, stopping at a newline.
    #[inline]
    pub fn skip_inline_ws(&mut self) {
        while let Some(&b) = self.d.get(self.p) {
            if is_inline_ws(b) {
                self.p += 1;
            } else {
                break;
            }
        }
    }

    /// Takes the non-whitespace run starting at the current offset (may be empty).
    #[inline]
    fn take_run(&mut self) -> &'a [u8] {
        let start = self.p;
        while let Some(&b) = self.d.get(self.p) {
            if b == b'\n' || is_inline_ws(b) {
                break;
            }
            self.p += 1;
        }
        &self.d[start..self.p]
    }

    /// The next whitespace-delimited word, crossing newlines (empty at end of input).
    pub fn word(&mut self) -> &'a [u8] {
        self.skip_ws();
        self.take_run()
    }

    /// The next token, crossing newlines. Fails at end of input, or on a `$` section
    /// marker (the section ended before the records its header announced).
    #[inline]
    pub fn token(&mut self, what: &str) -> PResult<&'a [u8]> {
        self.skip_ws();
        let start = self.p;
        let t = self.take_run();
        if t.is_empty() {
            return Err(Fail::at(
                start,
                ErrorKind::Truncated {
                    expected: what.to_string(),
                },
            ));
        }
        if t[0] == b'$' {
            return Err(Fail::at(
                start,
                ErrorKind::EarlyEnd {
                    expected: what.to_string(),
                    found: show(t),
                },
            ));
        }
        Ok(t)
    }

    /// The next token on the current line. `index` fields of `total` were already read on
    /// this line; if the line ends first, the error says how many were found.
    #[inline]
    pub fn token_inline(&mut self, what: &str, index: usize, total: usize) -> PResult<&'a [u8]> {
        self.skip_inline_ws();
        let start = self.p;
        let t = self.take_run();
        if t.is_empty() {
            if start >= self.d.len() {
                return Err(Fail::at(
                    start,
                    ErrorKind::Truncated {
                        expected: what.to_string(),
                    },
                ));
            }
            return Err(Fail::at(
                start,
                ErrorKind::TooFewFields {
                    what: what.to_string(),
                    expected: total,
                    found: index,
                },
            ));
        }
        Ok(t)
    }

    /// Requires the rest of the current line to be blank and moves past its newline.
    #[inline]
    pub fn end_line(&mut self, what: &str) -> PResult<()> {
        self.skip_inline_ws();
        match self.d.get(self.p) {
            None => Ok(()),
            Some(b'\n') => {
                self.p += 1;
                Ok(())
            }
            Some(_) => {
                let start = self.p;
                let first = self.take_run();
                let mut extra = 1;
                loop {
                    self.skip_inline_ws();
                    if self.take_run().is_empty() {
                        break;
                    }
                    extra += 1;
                }
                Err(Fail::at(
                    start,
                    ErrorKind::TooManyFields {
                        what: what.to_string(),
                        extra,
                        found: show(first),
                    },
                ))
            }
        }
    }

    /// Moves to the start of the next line (rest of the current line ignored).
    pub fn next_line(&mut self) {
        match memchr::memchr(b'\n', &self.d[self.p.min(self.d.len())..]) {
            Some(i) => self.p += i + 1,
            None => self.p = self.d.len(),
        }
    }

    /// Current offset (callers skip whitespace first to point at the next token).
    pub fn at(&self) -> usize {
        self.p
    }

    /// Next token as an unsigned integer.
    #[inline]
    pub fn u64(&mut self, what: &str) -> PResult<u64> {
        self.skip_ws();
        let start = self.p;
        let t = self.token(what)?;
        parse_u64(t).ok_or_else(|| not_int(start, t, what))
    }

    /// Next token as a signed integer that fits an `i32`.
    #[inline]
    pub fn i32(&mut self, what: &str) -> PResult<i32> {
        self.skip_ws();
        let start = self.p;
        let t = self.token(what)?;
        parse_i64(t)
            .and_then(|v| i32::try_from(v).ok())
            .ok_or_else(|| not_int(start, t, what))
    }

    /// Next token as a count (`usize`) of records that each take at least `min_bytes` bytes
    /// of text, refusing counts the rest of the input cannot hold (they are certainly wrong
    /// and would make us reserve absurd amounts of memory).
    pub fn count(&mut self, what: &str, min_bytes: u64) -> PResult<usize> {
        self.skip_ws();
        let start = self.p;
        let v = self.u64(what)?;
        let left = self.d.len().saturating_sub(self.p) as u64;
        if v.saturating_mul(min_bytes) > left {
            return Err(Fail::at(
                start,
                ErrorKind::CountTooLarge {
                    what: what.to_string(),
                    count: v,
                    left,
                },
            ));
        }
        Ok(v as usize)
    }

    /// Next token (crossing lines) as a finite float.
    #[inline]
    pub fn f64(&mut self, what: &str) -> PResult<f64> {
        self.skip_ws();
        let start = self.p;
        let t = self.token(what)?;
        parse_finite(t, start, what)
    }

    /// Next token on the current line as a finite float (see [`Text::token_inline`]).
    #[inline]
    pub fn f64_inline(&mut self, what: &str, index: usize, total: usize) -> PResult<f64> {
        self.skip_inline_ws();
        let start = self.p;
        let t = self.token_inline(what, index, total)?;
        parse_finite(t, start, what)
    }

    /// Next token on the current line as an unsigned integer.
    #[inline]
    pub fn u64_inline(&mut self, what: &str, index: usize, total: usize) -> PResult<u64> {
        self.skip_inline_ws();
        let start = self.p;
        let t = self.token_inline(what, index, total)?;
        parse_u64(t).ok_or_else(|| not_int(start, t, what))
    }

    /// Next token on the current line as an `i32`.
    #[inline]
    pub fn i32_inline(&mut self, what: &str, index: usize, total: usize) -> PResult<i32> {
        self.skip_inline_ws();
        let start = self.p;
        let t = self.token_inline(what, index, total)?;
        parse_i64(t)
            .and_then(|v| i32::try_from(v).ok())
            .ok_or_else(|| not_int(start, t, what))
    }

    /// Skips whitespace and requires the `$EndName` line of section `name`.
    pub fn expect_end(&mut self, name: &str) -> PResult<()> {
        self.skip_ws();
        let start = self.p;
        let t = self.take_run();
        if t.len() == name.len() + 4 && t.starts_with(b"$End") && &t[4..] == name.as_bytes() {
            self.skip_inline_ws();
            if self.d.get(self.p) == Some(&b'\n') {
                self.p += 1;
            }
            return Ok(());
        }
        let kind = if t.is_empty() {
            ErrorKind::Truncated {
                expected: format!("$End{name}"),
            }
        } else {
            ErrorKind::Unexpected {
                expected: format!("$End{name} (more records than the header announced?)"),
                found: show(t),
            }
        };
        Err(Fail::at(start, kind))
    }
}

fn not_int(pos: usize, t: &[u8], what: &str) -> Fail {
    Fail::at(
        pos,
        ErrorKind::NotANumber {
            expected: format!("an integer ({what})"),
            found: show(t),
        },
    )
}

fn parse_finite(t: &[u8], pos: usize, what: &str) -> PResult<f64> {
    let v = std::str::from_utf8(t)
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
        .ok_or_else(|| {
            Fail::at(
                pos,
                ErrorKind::NotANumber {
                    expected: format!("a number ({what})"),
                    found: show(t),
                },
            )
        })?;
    if !v.is_finite() {
        return Err(Fail::at(
            pos,
            ErrorKind::NotFinite {
                what: what.to_string(),
                found: show(t),
            },
        ));
    }
    Ok(v)
}

/// Parses a decimal unsigned integer (optional leading `+`), `None` on any other byte or on
/// overflow.
#[inline]
pub(crate) fn parse_u64(t: &[u8]) -> Option<u64> {
    let t = t.strip_prefix(b"+").unwrap_or(t);
    if t.is_empty() || t.len() > 20 {
        return None;
    }
    let mut v: u64 = 0;
    for &b in t {
        let d = b.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        v = v.checked_mul(10)?.checked_add(d as u64)?;
    }
    Some(v)
}

/// Parses a decimal signed integer.
#[inline]
pub(crate) fn parse_i64(t: &[u8]) -> Option<i64> {
    if let Some(rest) = t.strip_prefix(b"-") {
        let v = parse_u64(rest)?;
        if v <= i64::MAX as u64 + 1 {
            Some((v as i128).wrapping_neg() as i64)
        } else {
            None
        }
    } else {
        parse_u64(t).and_then(|v| i64::try_from(v).ok())
    }
}

/// Binary cursor over packed data (little-endian unless the endianness probe said otherwise).
pub(crate) struct Bin<'a> {
    /// The whole input.
    pub d: &'a [u8],
    /// Current offset.
    pub p: usize,
    /// True when the file's byte order is big-endian.
    pub swap: bool,
}

impl<'a> Bin<'a> {
    /// A cursor at offset `p`.
    pub fn new(d: &'a [u8], p: usize, swap: bool) -> Self {
        Bin { d, p, swap }
    }

    /// Takes `n` bytes, failing with a size mismatch when fewer remain.
    #[inline]
    pub fn take(&mut self, n: u64, what: &str) -> PResult<&'a [u8]> {
        let avail = (self.d.len() - self.p.min(self.d.len())) as u64;
        if n > avail {
            return Err(Fail::bin(
                self.p,
                ErrorKind::BinarySize {
                    what: what.to_string(),
                    needed: n,
                    available: avail,
                },
            ));
        }
        let s = &self.d[self.p..self.p + n as usize];
        self.p += n as usize;
        Ok(s)
    }

    /// A 4-byte signed integer.
    #[inline]
    pub fn i32(&mut self, what: &str) -> PResult<i32> {
        let s = self.take(4, what)?;
        let a = [s[0], s[1], s[2], s[3]];
        Ok(if self.swap {
            i32::from_be_bytes(a)
        } else {
            i32::from_le_bytes(a)
        })
    }

    /// An 8-byte unsigned integer (`size_t`).
    #[inline]
    pub fn u64(&mut self, what: &str) -> PResult<u64> {
        let s = self.take(8, what)?;
        Ok(u64_at(s, self.swap))
    }

    /// A count stored as `size_t`, checked against the bytes left (`min_bytes` per record).
    pub fn count(&mut self, what: &str, min_bytes: u64) -> PResult<usize> {
        let start = self.p;
        let v = self.u64(what)?;
        let avail = (self.d.len() - self.p.min(self.d.len())) as u64;
        if v.saturating_mul(min_bytes) > avail {
            return Err(Fail::bin(
                start,
                ErrorKind::BinarySize {
                    what: format!("{what} {v}"),
                    needed: v.saturating_mul(min_bytes),
                    available: avail,
                },
            ));
        }
        Ok(v as usize)
    }

    /// An 8-byte float, required to be finite.
    #[inline]
    pub fn f64(&mut self, what: &str) -> PResult<f64> {
        let start = self.p;
        let s = self.take(8, what)?;
        let v = f64::from_bits(u64_at(s, self.swap));
        if !v.is_finite() {
            return Err(Fail::bin(
                start,
                ErrorKind::NotFinite {
                    what: what.to_string(),
                    found: v.to_string(),
                },
            ));
        }
        Ok(v)
    }
}

/// Reads an 8-byte integer from the first 8 bytes of `s` (caller guarantees the length).
#[inline]
pub(crate) fn u64_at(s: &[u8], swap: bool) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&s[..8]);
    if swap {
        u64::from_be_bytes(a)
    } else {
        u64::from_le_bytes(a)
    }
}

/// Reads a 4-byte integer from the first 4 bytes of `s`.
#[inline]
pub(crate) fn i32_at(s: &[u8], swap: bool) -> i32 {
    let a = [s[0], s[1], s[2], s[3]];
    if swap {
        i32::from_be_bytes(a)
    } else {
        i32::from_le_bytes(a)
    }
}

/// Decodes `n` finite doubles from `s` (length `8 n`), reporting the first non-finite one.
pub(crate) fn f64s_into(
    s: &[u8],
    base: usize,
    swap: bool,
    what: &str,
    out: &mut Vec<f64>,
) -> PResult<()> {
    out.reserve(s.len() / 8);
    for (i, c) in s.chunks_exact(8).enumerate() {
        let v = f64::from_bits(u64_at(c, swap));
        if !v.is_finite() {
            return Err(Fail::bin(
                base + 8 * i,
                ErrorKind::NotFinite {
                    what: what.to_string(),
                    found: v.to_string(),
                },
            ));
        }
        out.push(v);
    }
    Ok(())
}
