//! The bytes of a `.vdb` file, read in order through a window that ends where the file (or the
//! grid being read) ends, and the reader's errors before they are tied to the file's path.

use std::fmt;
use std::io::{Read, Seek, SeekFrom};

use crate::error::{Ctx, Error};

/// Why reading failed; [`Fail::into_error`] names the file.
pub(super) struct Fail {
    kind: FailKind,
    detail: String,
}

enum FailKind {
    Bad,
    Unsupported,
    Limit { requested: u64, allowed: u64 },
    Io(std::io::Error),
}

/// The reader's result type.
pub(super) type Res<T> = Result<T, Fail>;

impl Fail {
    /// Malformed content.
    pub fn bad(detail: impl fmt::Display) -> Self {
        Fail { kind: FailKind::Bad, detail: detail.to_string() }
    }

    /// Well-formed but not supported.
    pub fn unsupported(detail: impl fmt::Display) -> Self {
        Fail { kind: FailKind::Unsupported, detail: detail.to_string() }
    }

    /// More memory than the limits allow.
    pub fn limit(what: impl fmt::Display, requested: u64, allowed: u64) -> Self {
        Fail { kind: FailKind::Limit { requested, allowed }, detail: what.to_string() }
    }

    /// Prefixes the detail with where it happened (`grid "density"`, `leaf [8, 0, 16]`).
    pub fn within(mut self, scope: impl fmt::Display) -> Self {
        self.detail = format!("{scope}: {}", self.detail);
        self
    }

    /// The crate's error for this file.
    pub fn into_error(self, ctx: Ctx) -> Error {
        match self.kind {
            FailKind::Bad => ctx.bad(self.detail),
            FailKind::Unsupported => ctx.unsupported(self.detail),
            FailKind::Limit { requested, allowed } => ctx.limit(self.detail, requested, allowed),
            FailKind::Io(e) => ctx.io(e),
        }
    }
}

/// Anything the reader can read from: a file or bytes in memory.
pub(super) trait ReadSeek: Read + Seek {}
impl<T: Read + Seek> ReadSeek for T {}

/// Bytes below this many are skipped by reading them, not by seeking (a buffered file drops
/// its buffer on every seek).
const SKIP_BY_READING: u64 = 64 << 10;

/// A read position in the file and the end of the window it may read up to (the file's end,
/// or the end of the grid being read).
pub(super) struct Src<'a> {
    r: &'a mut dyn ReadSeek,
    pos: u64,
    end: u64,
    len: u64,
}

impl<'a> Src<'a> {
    /// Reads `r`, `len` bytes long, from its start.
    pub fn new(r: &'a mut dyn ReadSeek, len: u64) -> Self {
        Src { r, pos: 0, end: len, len }
    }

    /// The byte offset of the next read.
    pub fn pos(&self) -> u64 {
        self.pos
    }

    /// The file's length.
    pub fn len(&self) -> u64 {
        self.len
    }

    /// Bytes left before the end of the window.
    pub fn left(&self) -> u64 {
        self.end.saturating_sub(self.pos)
    }

    /// Narrows (or, with the file's length, widens back) the window to end at `end`.
    pub fn set_end(&mut self, end: u64) {
        self.end = end.min(self.len);
    }

    /// Moves to byte `pos` of the file.
    pub fn seek(&mut self, pos: u64) -> Res<()> {
        if pos > self.len {
            return Err(Fail::bad(format!("byte {pos} is past the end of the file ({} bytes)", self.len)));
        }
        self.r.seek(SeekFrom::Start(pos)).map_err(io)?;
        self.pos = pos;
        Ok(())
    }

    /// Fails unless `n` more bytes are there for `what`.
    pub fn need(&self, n: u64, what: &str) -> Res<()> {
        if n <= self.left() {
            return Ok(());
        }
        let end = if self.end == self.len { "the end of the file" } else { "the end of the grid's data" };
        Err(Fail::bad(format!(
            "byte {}: {what} needs {n} bytes, but only {} are left before {end} (truncated or corrupt file?)",
            self.pos,
            self.left()
        )))
    }

    /// Fills `buf` with the next bytes.
    pub fn fill(&mut self, buf: &mut [u8], what: &str) -> Res<()> {
        self.need(buf.len() as u64, what)?;
        self.r.read_exact(buf).map_err(io)?;
        self.pos += buf.len() as u64;
        Ok(())
    }

    /// The next `N` bytes.
    pub fn array<const N: usize>(&mut self, what: &str) -> Res<[u8; N]> {
        let mut a = [0u8; N];
        self.fill(&mut a, what)?;
        Ok(a)
    }

    /// The next byte.
    pub fn u8(&mut self, what: &str) -> Res<u8> {
        let [b] = self.array::<1>(what)?;
        Ok(b)
    }

    /// The next little-endian `u32`.
    pub fn u32(&mut self, what: &str) -> Res<u32> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }

    /// The next little-endian `i32`.
    pub fn i32(&mut self, what: &str) -> Res<i32> {
        Ok(i32::from_le_bytes(self.array(what)?))
    }

    /// The next little-endian `i64`.
    pub fn i64(&mut self, what: &str) -> Res<i64> {
        Ok(i64::from_le_bytes(self.array(what)?))
    }

    /// The next little-endian `f64`.
    pub fn f64(&mut self, what: &str) -> Res<f64> {
        Ok(f64::from_le_bytes(self.array(what)?))
    }

    /// Three `i32` (a node origin).
    pub fn coord(&mut self, what: &str) -> Res<[i32; 3]> {
        Ok([self.i32(what)?, self.i32(what)?, self.i32(what)?])
    }

    /// Three `f64` (a vector of a map).
    pub fn vec3(&mut self, what: &str) -> Res<[f64; 3]> {
        Ok([self.f64(what)?, self.f64(what)?, self.f64(what)?])
    }

    /// `words.len()` little-endian `u64` (a node mask).
    pub fn words(&mut self, words: &mut [u64], what: &str) -> Res<()> {
        self.need(8 * words.len() as u64, what)?;
        for w in words {
            *w = u64::from_le_bytes(self.array(what)?);
        }
        Ok(())
    }

    /// Skips `n` bytes.
    pub fn skip(&mut self, n: u64, what: &str) -> Res<()> {
        self.need(n, what)?;
        if n >= SKIP_BY_READING {
            return self.seek(self.pos + n);
        }
        let mut scratch = [0u8; 512];
        let mut left = n;
        while left > 0 {
            let step = left.min(scratch.len() as u64) as usize; // at most 512
            self.r.read_exact(&mut scratch[..step]).map_err(io)?;
            left -= step as u64;
        }
        self.pos += n;
        Ok(())
    }

    /// Reads `n` bytes into `buf` (resized to `n`; the caller has bounded `n`).
    pub fn read_vec(&mut self, n: u64, buf: &mut Vec<u8>, what: &str) -> Res<()> {
        self.need(n, what)?;
        buf.clear();
        buf.resize(n as usize, 0);
        self.fill(buf, what)
    }

    /// A string: a `u32` length and that many bytes (not necessarily UTF-8: converted lossily).
    /// Longer than `max` is an error, found before anything is allocated.
    pub fn string(&mut self, max: u32, what: &str) -> Res<String> {
        let at = self.pos;
        let n = self.u32(what)?;
        if n > max {
            return Err(Fail::bad(format!("byte {at}: {what}: length {n} is over the {max} bytes accepted")));
        }
        let mut bytes = Vec::new();
        self.read_vec(u64::from(n), &mut bytes, what)?;
        Ok(String::from_utf8_lossy(&bytes).into_owned())
    }

    /// A string of at most `max` bytes, or `None` (skipped) when it is longer: for names that
    /// only matter when they are one of a few short ones.
    pub fn short_string(&mut self, max: u32, what: &str) -> Res<Option<String>> {
        let n = self.u32(what)?;
        if n > max {
            self.skip(u64::from(n), what)?;
            return Ok(None);
        }
        let mut bytes = Vec::new();
        self.read_vec(u64::from(n), &mut bytes, what)?;
        Ok(Some(String::from_utf8_lossy(&bytes).into_owned()))
    }
}

fn io(e: std::io::Error) -> Fail {
    Fail { kind: FailKind::Io(e), detail: String::new() }
}

/// A name or type from the file as a message shows it: quoted with its control characters
/// escaped (the message stays on one line) and cut after 80 characters.
pub fn shown(s: &str) -> String {
    const MAX: usize = 80;
    match s.char_indices().nth(MAX) {
        None => format!("{s:?}"),
        Some((end, _)) => format!("{:?}…", &s[..end]),
    }
}
