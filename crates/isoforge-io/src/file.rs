//! Opening input files: regular files only (no devices, FIFOs, sockets or folders), read no
//! further than the size they had when opened, so no input can make a reader read without end.

use std::fs::{File, FileType, Metadata};
use std::io::{self, Read, Seek, SeekFrom};
use std::path::Path;

use crate::error::{Ctx, Result};

/// What a non-regular file is, for messages ("a character device").
pub(crate) fn kind_name(t: &FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a folder"
    } else if t.is_file() {
        "a regular file"
    } else {
        "not a regular file"
    }
}

fn check_regular(ctx: Ctx, meta: &Metadata) -> Result<()> {
    let t = meta.file_type();
    if t.is_file() {
        return Ok(());
    }
    Err(if t.is_dir() {
        ctx.unsupported("is a folder, where a file is expected")
    } else {
        ctx.unsupported(format!(
            "is {}, not a regular file (isoforge reads volumes and meshes from regular files only)",
            kind_name(&t)
        ))
    })
}

/// A regular file opened for reading, and its length when opened.
pub(crate) struct Input {
    pub file: File,
    pub len: u64,
}

/// Opens `path` (following symbolic links) if it is a regular file.
///
/// The type is checked before opening (a FIFO would block the open) and again on the opened
/// handle (the path may have been swapped in between); the open itself does not block.
pub(crate) fn open(ctx: Ctx, path: &Path) -> Result<Input> {
    check_regular(ctx, &std::fs::metadata(path).map_err(|e| ctx.io(e))?)?;
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(|e| ctx.io(e))?;
    let meta = file.metadata().map_err(|e| ctx.io(e))?;
    check_regular(ctx, &meta)?;
    Ok(Input { file, len: meta.len() })
}

/// Reads the whole regular file `path`, refusing one longer than `max` bytes.
pub(crate) fn read_all(ctx: Ctx, path: &Path, max: u64) -> Result<Vec<u8>> {
    let Input { file, len } = open(ctx, path)?;
    if len > max {
        return Err(ctx.limit("the file", len, max));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(len).read_to_end(&mut bytes).map_err(|e| ctx.io(e))?;
    Ok(bytes)
}

/// Reads at most the first `max` bytes of the regular file `path`.
pub(crate) fn read_prefix(ctx: Ctx, path: &Path, max: u64) -> Result<Vec<u8>> {
    let Input { file, len } = open(ctx, path)?;
    let n = len.min(max);
    let mut bytes = Vec::with_capacity(n as usize);
    file.take(n).read_to_end(&mut bytes).map_err(|e| ctx.io(e))?;
    Ok(bytes)
}

/// A file read no further than `len` bytes (its size when opened), seekable within them: a file
/// that grows while it is read cannot make a reader read more than it planned for.
pub(crate) struct Bounded {
    file: File,
    pos: u64,
    len: u64,
}

impl Bounded {
    pub fn new(input: Input) -> Self {
        Bounded { file: input.file, pos: 0, len: input.len }
    }
}

impl Read for Bounded {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let left = self.len.saturating_sub(self.pos);
        let n = (buf.len() as u64).min(left) as usize;
        if n == 0 {
            return Ok(0);
        }
        let got = self.file.read(&mut buf[..n])?;
        self.pos += got as u64;
        Ok(got)
    }
}

impl Seek for Bounded {
    fn seek(&mut self, to: SeekFrom) -> io::Result<u64> {
        let target = match to {
            SeekFrom::Start(p) => Some(p),
            SeekFrom::End(d) => self.len.checked_add_signed(d),
            SeekFrom::Current(d) => self.pos.checked_add_signed(d),
        };
        let target = target.ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "seek before the start"))?;
        self.pos = self.file.seek(SeekFrom::Start(target))?;
        Ok(self.pos)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounded_reads_stop_at_the_length_seen_at_open() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("grow.bin");
        std::fs::write(&p, [1u8; 10]).unwrap();
        let ctx = Ctx::new(&p, "test");
        let mut b = Bounded::new(open(ctx, &p).unwrap());
        // The file grows after opening: the reader still sees 10 bytes.
        std::io::Write::write_all(&mut std::fs::OpenOptions::new().append(true).open(&p).unwrap(), &[2u8; 100])
            .unwrap();
        let mut all = Vec::new();
        b.read_to_end(&mut all).unwrap();
        assert_eq!(all, vec![1u8; 10]);
        assert_eq!(b.seek(SeekFrom::End(-3)).unwrap(), 7);
        assert_eq!(b.seek(SeekFrom::Current(1)).unwrap(), 8);
        assert!(b.seek(SeekFrom::Current(-9)).is_err());
    }

    #[test]
    #[cfg(unix)]
    fn issue_10_devices_fifos_and_folders_are_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        for (p, kind) in [(Path::new("/dev/zero"), "a character device"), (dir.path(), "is a folder")] {
            let e = open(Ctx::new(p, "test"), p).err().unwrap().to_string();
            assert!(e.starts_with(&format!("{}: ", p.display())), "{e}");
            assert!(e.contains(kind), "{e}");
        }
        #[cfg(unix)]
        {
            let fifo = dir.path().join("pipe");
            let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
            // SAFETY: a valid NUL-terminated path.
            assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
            // Would block forever if the FIFO were opened for reading without a writer.
            let e = read_all(Ctx::new(&fifo, "test"), &fifo, 1 << 20).err().unwrap().to_string();
            assert!(e.contains("a FIFO (named pipe), not a regular file"), "{e}");
        }
    }
}
