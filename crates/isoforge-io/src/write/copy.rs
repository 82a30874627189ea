//! Copies between files at offsets, for writers that assemble an output from scratch files
//! (the streamed PLY's vertices and faces, the streamed STL's quads): in the kernel where it can,
//! else through a buffer.

use std::io;

/// Copies bytes `range` of the concatenation of `parts` (files and the lengths taken from each)
/// into `to` at `at + range.start`.
pub(super) fn copy_span(
    parts: &[(&std::fs::File, u64)],
    to: &std::fs::File,
    at: u64,
    range: std::ops::Range<u64>,
) -> io::Result<()> {
    let mut start = 0;
    for &(from, len) in parts {
        let (lo, hi) = (range.start.max(start), range.end.min(start + len));
        if lo < hi {
            copy_at(from, lo - start, to, at + lo, hi - lo)?;
        }
        start += len;
    }
    Ok(())
}

/// Copies `len` bytes of `from` at `from_at` into `to` at `to_at` (neither file's position is
/// used or moved): in the kernel (`copy_file_range`) where it can, else through a buffer.
pub(super) fn copy_at(from: &std::fs::File, from_at: u64, to: &std::fs::File, to_at: u64, len: u64) -> io::Result<()> {
    let done = copy_in_kernel(from, from_at, to, to_at, len)?;
    copy_buffered(from, from_at + done, to, to_at + done, len - done)
}

/// The part of [`copy_at`] the kernel copies (`copy_file_range`), from the start: all of it, or
/// what it did before saying it cannot copy between these files.
#[cfg(target_os = "linux")]
fn copy_in_kernel(from: &std::fs::File, from_at: u64, to: &std::fs::File, to_at: u64, len: u64) -> io::Result<u64> {
    use std::os::fd::AsRawFd;
    let mut done = 0u64;
    while done < len {
        let (mut off_in, mut off_out) = ((from_at + done) as libc::loff_t, (to_at + done) as libc::loff_t);
        let want = usize::try_from(len - done).unwrap_or(usize::MAX).min(1 << 30);
        // SAFETY: both descriptors are open files borrowed for the call; the offsets are locals
        // the kernel updates; no memory of ours is read or written.
        let n = unsafe { libc::copy_file_range(from.as_raw_fd(), &mut off_in, to.as_raw_fd(), &mut off_out, want, 0) };
        if n > 0 {
            done += n as u64;
            continue;
        }
        if n == 0 {
            return Err(io::Error::new(io::ErrorKind::UnexpectedEof, "a scratch file ended early"));
        }
        let e = io::Error::last_os_error();
        match e.raw_os_error() {
            Some(libc::EINTR) => continue,
            // Not supported between these files: the rest goes through a buffer.
            Some(libc::ENOSYS | libc::EXDEV | libc::EINVAL | libc::EOPNOTSUPP | libc::EBADF) => break,
            _ => return Err(e),
        }
    }
    Ok(done)
}

/// No in-kernel copy off Linux: everything goes through the buffer.
#[cfg(not(target_os = "linux"))]
fn copy_in_kernel(_: &std::fs::File, _: u64, _: &std::fs::File, _: u64, _: u64) -> io::Result<u64> {
    Ok(0)
}

/// [`copy_at`] through a 1 MiB buffer (platforms and file pairs without an in-kernel copy).
fn copy_buffered(from: &std::fs::File, from_at: u64, to: &std::fs::File, to_at: u64, len: u64) -> io::Result<()> {
    let mut buf = vec![0u8; (1 << 20).min(len) as usize];
    let mut done = 0u64;
    while done < len {
        let n = buf.len().min((len - done) as usize);
        positioned::read_exact_at(from, &mut buf[..n], from_at + done)?;
        positioned::write_all_at(to, &buf[..n], to_at + done)?;
        done += n as u64;
    }
    Ok(())
}

/// Reads and writes at an offset, for the two halves [`copy_at`] copies at once: `pread` and
/// `pwrite` on Unix; on Windows `seek_read` / `seek_write`, which also move the file's cursor
/// (its position is set explicitly after the copy).
mod positioned {
    use std::fs::File;
    use std::io;

    #[cfg(unix)]
    pub(super) fn read_exact_at(f: &File, buf: &mut [u8], at: u64) -> io::Result<()> {
        std::os::unix::fs::FileExt::read_exact_at(f, buf, at)
    }

    #[cfg(unix)]
    pub(super) fn write_all_at(f: &File, buf: &[u8], at: u64) -> io::Result<()> {
        std::os::unix::fs::FileExt::write_all_at(f, buf, at)
    }

    #[cfg(windows)]
    pub(super) fn read_exact_at(f: &File, mut buf: &mut [u8], mut at: u64) -> io::Result<()> {
        use std::os::windows::fs::FileExt;
        while !buf.is_empty() {
            match f.seek_read(buf, at) {
                Ok(0) => return Err(io::Error::new(io::ErrorKind::UnexpectedEof, "a scratch file ended early")),
                Ok(n) => {
                    buf = &mut buf[n..];
                    at += n as u64;
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }

    #[cfg(windows)]
    pub(super) fn write_all_at(f: &File, mut buf: &[u8], mut at: u64) -> io::Result<()> {
        use std::os::windows::fs::FileExt;
        while !buf.is_empty() {
            match f.seek_write(buf, at) {
                Ok(0) => return Err(io::Error::new(io::ErrorKind::WriteZero, "the output took no bytes")),
                Ok(n) => {
                    buf = &buf[n..];
                    at += n as u64;
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }

    #[cfg(not(any(unix, windows)))]
    pub(super) fn read_exact_at(_: &File, _: &mut [u8], _: u64) -> io::Result<()> {
        Err(io::Error::new(io::ErrorKind::Unsupported, "positioned reads on this platform"))
    }

    #[cfg(not(any(unix, windows)))]
    pub(super) fn write_all_at(_: &File, _: &[u8], _: u64) -> io::Result<()> {
        Err(io::Error::new(io::ErrorKind::Unsupported, "positioned writes on this platform"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Seek, SeekFrom, Write};

    /// Both copies (in the kernel and through the buffer) put exactly the span asked for at the
    /// offset asked for, across the buffer's 1 MiB steps, and leave the rest of the output alone.
    #[test]
    fn copies_a_span_at_an_offset() {
        let len = (1 << 20) + 4321;
        let src: Vec<u8> = (0..len + 300).map(|i| (i * 7 + i / 251) as u8).collect();
        for buffered in [false, true] {
            let mut from = tempfile::tempfile().unwrap();
            from.write_all(&src).unwrap();
            let mut to = tempfile::tempfile().unwrap();
            to.write_all(&[0xAA; 100]).unwrap();
            let (at, n) = (100u64, len as u64);
            if buffered {
                copy_buffered(&from, 200, &to, at, n).unwrap();
            } else {
                copy_at(&from, 200, &to, at, n).unwrap();
            }
            let mut got = Vec::new();
            to.seek(SeekFrom::Start(0)).unwrap();
            to.read_to_end(&mut got).unwrap();
            assert_eq!(got.len(), 100 + len, "buffered {buffered}");
            assert!(got[..100].iter().all(|&b| b == 0xAA), "buffered {buffered}: bytes before the span");
            assert!(got[100..] == src[200..200 + len], "buffered {buffered}: the span");
            // Past the end of the source: an error, not a short copy.
            assert!(copy_buffered(&from, src.len() as u64 - 10, &to, 0, 20).is_err());
        }
    }
}
