//! Blosc1 frames: the chunks OpenVDB writes with `COMPRESS_BLOSC` (c-blosc 1.x, format 2).
//!
//! ```text
//! | version | versionlz | flags | typesize | nbytes u32 | blocksize u32 | cbytes u32 |  16-byte header
//! | bstart[0] … bstart[nblocks-1] (u32, offsets from the frame's start)              |
//! | per block, per split: csize i32, then csize bytes (raw when csize = split size)   |
//! ```
//!
//! A block is cut into `typesize` splits (one per byte lane of the shuffle) when it is not the
//! short last block, the "don't split" flag (0x10) is clear, `typesize` ≤ 16 and the block holds
//! at least 128 elements; each split is compressed on its own. Flag 0x01: the block's bytes are
//! byte-shuffled (all first bytes of each element, then all second bytes…); 0x02: the frame is a
//! plain copy; 0x04: bit-shuffled (not supported, OpenVDB never asks for it). The codec is in the
//! top three bits: lz4 (what OpenVDB asks for) and zlib are decoded, blosclz, snappy and zstd are
//! refused by name.
//!
//! Every length is checked against the frame and the output before it is used: the output is
//! exactly `out.len()` bytes or the frame is refused.

use super::input::{Fail, Res};

const HEADER: usize = 16;
/// c-blosc's `BLOSC_VERSION_FORMAT` since 1.x with several codecs.
const FORMAT_VERSION: u8 = 2;
const SHUFFLE: u8 = 0x01;
const MEMCPYED: u8 = 0x02;
const BITSHUFFLE: u8 = 0x04;
const RESERVED: u8 = 0x08;
const DONT_SPLIT: u8 = 0x10;
/// c-blosc's `MAX_SPLITS` and `MIN_BUFFERSIZE`: when a block is split into byte lanes.
const MAX_SPLITS: usize = 16;
const MIN_SPLIT_ELEMENTS: usize = 128;

#[derive(Clone, Copy)]
enum Codec {
    Lz4,
    Zlib,
}

/// Decodes the blosc frame `src` into `out`, which must be exactly the frame's uncompressed
/// size. `tmp` is scratch space (a block before unshuffling).
pub(super) fn decompress(src: &[u8], out: &mut [u8], tmp: &mut Vec<u8>) -> Res<()> {
    let Some(&[version, versionlz, flags, typesize, n0, n1, n2, n3, b0, b1, b2, b3, c0, c1, c2, c3]) =
        src.first_chunk::<HEADER>()
    else {
        return Err(Fail::bad(format!("a blosc frame of {} bytes is shorter than its 16-byte header", src.len())));
    };
    let nbytes = u32::from_le_bytes([n0, n1, n2, n3]) as usize;
    let blocksize = u32::from_le_bytes([b0, b1, b2, b3]) as usize;
    let cbytes = u32::from_le_bytes([c0, c1, c2, c3]) as usize;
    let typesize = usize::from(typesize);
    if nbytes != out.len() {
        return Err(Fail::bad(format!("blosc header: {nbytes} bytes uncompressed, expected {}", out.len())));
    }
    if nbytes == 0 {
        return Ok(()); // c-blosc reads nothing else of an empty frame
    }
    if version != FORMAT_VERSION {
        return Err(Fail::unsupported(format!("blosc format version {version} (expected {FORMAT_VERSION})")));
    }
    if flags & RESERVED != 0 {
        return Err(Fail::bad(format!("blosc flags {flags:#04x}: the reserved bit 0x08 is set")));
    }
    if cbytes != src.len() {
        return Err(Fail::bad(format!("blosc header: {cbytes} compressed bytes, but the chunk has {}", src.len())));
    }
    if typesize == 0 {
        return Err(Fail::bad("blosc header: type size 0"));
    }
    if blocksize == 0 || blocksize > nbytes {
        return Err(Fail::bad(format!("blosc header: block size {blocksize} for {nbytes} bytes")));
    }
    if flags & MEMCPYED != 0 {
        let data = src.get(HEADER..).unwrap_or_default();
        if data.len() != nbytes {
            return Err(Fail::bad(format!(
                "blosc frame stored uncompressed holds {} bytes, expected {nbytes}",
                data.len()
            )));
        }
        out.copy_from_slice(data);
        return Ok(());
    }
    let codec = match flags >> 5 {
        1 if versionlz == 1 => Codec::Lz4,
        3 if versionlz == 1 => Codec::Zlib,
        1 | 3 => return Err(Fail::unsupported(format!("blosc codec version {versionlz} (expected 1)"))),
        0 => return Err(Fail::unsupported("blosc codec blosclz is not supported (OpenVDB writes lz4)")),
        2 => return Err(Fail::unsupported("blosc codec snappy is not supported (OpenVDB writes lz4)")),
        4 => return Err(Fail::unsupported("blosc codec zstd is not supported (OpenVDB writes lz4)")),
        c => return Err(Fail::bad(format!("blosc codec number {c} is unknown"))),
    };
    if flags & BITSHUFFLE != 0 {
        return Err(Fail::unsupported(
            "bit-shuffled blosc frames are not supported (OpenVDB writes byte-shuffled ones)",
        ));
    }
    let nblocks = nbytes.div_ceil(blocksize);
    let leftover = nbytes % blocksize;
    let starts = src.get(HEADER..HEADER + 4 * nblocks).ok_or_else(|| {
        Fail::bad(format!("blosc frame of {} bytes is too short for the starts of its {nblocks} blocks", src.len()))
    })?;
    tmp.clear();
    tmp.resize(blocksize, 0);
    for (j, (start, dest)) in starts.chunks_exact(4).zip(out.chunks_mut(blocksize)).enumerate() {
        let start = u32::from_le_bytes([start[0], start[1], start[2], start[3]]) as usize;
        let last_short = j + 1 == nblocks && leftover > 0;
        block(src, start, last_short, typesize, flags, codec, dest, tmp)
            .map_err(|f| f.within(format!("blosc block {j}")))?;
    }
    Ok(())
}

/// Decodes one block starting at byte `start` of `src` into `dest` (the block's size).
#[allow(clippy::too_many_arguments)]
fn block(
    src: &[u8],
    start: usize,
    last_short: bool,
    typesize: usize,
    flags: u8,
    codec: Codec,
    dest: &mut [u8],
    tmp: &mut [u8],
) -> Res<()> {
    let bsize = dest.len();
    let shuffle = flags & SHUFFLE != 0 && typesize > 1;
    let splits =
        if flags & DONT_SPLIT == 0 && typesize <= MAX_SPLITS && bsize / typesize >= MIN_SPLIT_ELEMENTS && !last_short {
            typesize
        } else {
            1
        };
    if !bsize.is_multiple_of(splits) {
        return Err(Fail::bad(format!("{bsize} bytes do not split into {splits} lanes")));
    }
    if !shuffle {
        return splits_into(src, start, splits, codec, dest);
    }
    let target = tmp.get_mut(..bsize).ok_or_else(|| Fail::bad("block larger than the block size"))?;
    splits_into(src, start, splits, codec, target)?;
    unshuffle(target, dest, typesize);
    Ok(())
}

/// Decodes the `splits` splits of a block starting at byte `start` of `src` into `target`.
fn splits_into(src: &[u8], start: usize, splits: usize, codec: Codec, target: &mut [u8]) -> Res<()> {
    let split_size = target.len() / splits;
    let mut at = start;
    for (k, part) in target.chunks_exact_mut(split_size.max(1)).enumerate() {
        let csize = src
            .get(at..at + 4)
            .map(|b| i32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .ok_or_else(|| Fail::bad(format!("split {k} starts at byte {at}, past the frame's {} bytes", src.len())))?;
        at += 4;
        let data = usize::try_from(csize)
            .ok()
            .and_then(|n| src.get(at..at.checked_add(n)?))
            .ok_or_else(|| Fail::bad(format!("split {k}: {csize} compressed bytes at byte {at} run past the frame")))?;
        at += data.len();
        if data.len() == split_size {
            part.copy_from_slice(data); // stored as is
            continue;
        }
        match codec {
            Codec::Lz4 => {
                let got = lz4_flex::block::decompress_into(data, part)
                    .map_err(|e| Fail::bad(format!("split {k}: corrupt lz4 data ({e})")))?;
                if got != split_size {
                    return Err(Fail::bad(format!("split {k} decodes to {got} bytes, expected {split_size}")));
                }
            }
            Codec::Zlib => zlib(data, part).map_err(|e| e.within(format!("split {k}")))?,
        }
    }
    Ok(())
}

/// Inflates the zlib stream `data` into exactly `out` (OpenVDB's zip chunks, blosc's zlib
/// codec): a stream decoding to more or fewer bytes is refused.
pub(super) fn zlib(data: &[u8], out: &mut [u8]) -> Res<()> {
    let mut z = flate2::Decompress::new(true);
    let status = z
        .decompress(data, out, flate2::FlushDecompress::Finish)
        .map_err(|e| Fail::bad(format!("corrupt zlib data ({e})")))?;
    let got = z.total_out();
    let want = out.len() as u64;
    match status {
        flate2::Status::StreamEnd if got == want => Ok(()),
        flate2::Status::StreamEnd => Err(Fail::bad(format!("zlib data ends after {got} of the {want} bytes expected"))),
        _ if got == want => Err(Fail::bad(format!("zlib data decodes to more than the {want} bytes expected"))),
        _ => Err(Fail::bad(format!("zlib data ends after {got} of the {want} bytes expected"))),
    }
}

/// Undoes blosc's byte shuffle of one block: `src` holds byte 0 of every element, then byte 1…;
/// the bytes after the last whole element were not shuffled.
fn unshuffle(src: &[u8], dest: &mut [u8], typesize: usize) {
    let elements = src.len() / typesize;
    let whole = elements * typesize;
    for (lane, bytes) in src[..whole].chunks_exact(elements.max(1)).enumerate() {
        for (i, &b) in bytes.iter().enumerate() {
            if let Some(d) = dest.get_mut(i * typesize + lane) {
                *d = b;
            }
        }
    }
    dest[whole..].copy_from_slice(&src[whole..]);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(flags: u8, typesize: u8, nbytes: u32, blocksize: u32, cbytes: u32) -> Vec<u8> {
        let mut h = vec![FORMAT_VERSION, 1, flags, typesize];
        h.extend(nbytes.to_le_bytes());
        h.extend(blocksize.to_le_bytes());
        h.extend(cbytes.to_le_bytes());
        h
    }

    #[test]
    fn unshuffle_restores_elements_and_keeps_the_tail() {
        // Elements [1 2 3 4] [5 6 7 8] shuffled: 1 5 2 6 3 7 4 8, then one unshuffled byte 9.
        let src = [1, 5, 2, 6, 3, 7, 4, 8, 9];
        let mut dest = [0u8; 9];
        unshuffle(&src, &mut dest, 4);
        assert_eq!(dest, [1, 2, 3, 4, 5, 6, 7, 8, 9]);
    }

    #[test]
    fn stored_splits_and_a_short_last_block_decode() {
        // 600 bytes, typesize 4, blocks of 512: block 0 splits into 4 lanes of 128 (stored as
        // is, shuffled), block 1 (88 bytes) is one stored split, also shuffled.
        let data: Vec<u8> = (0..600u32).map(|i| (i * 7 % 251) as u8).collect();
        let shuffle = |block: &[u8]| {
            let n = block.len() / 4;
            let mut s = vec![0u8; block.len()];
            for i in 0..n {
                for j in 0..4 {
                    s[j * n + i] = block[i * 4 + j];
                }
            }
            s
        };
        let mut body = Vec::new();
        let mut starts = Vec::new();
        let base = 16 + 8;
        for (j, block) in data.chunks(512).enumerate() {
            starts.push((base + body.len()) as u32);
            let s = shuffle(block);
            let splits: Vec<&[u8]> = if j == 0 { s.chunks(128).collect() } else { vec![&s[..]] };
            for split in splits {
                body.extend((split.len() as i32).to_le_bytes());
                body.extend(split);
            }
        }
        let total = (base + body.len()) as u32;
        let mut frame = header(SHUFFLE | (1 << 5), 4, 600, 512, total);
        for s in starts {
            frame.extend(s.to_le_bytes());
        }
        frame.extend(&body);
        let mut out = vec![0u8; 600];
        assert!(decompress(&frame, &mut out, &mut Vec::new()).is_ok());
        assert_eq!(out, data);
        // A frame declaring another size, or cut short, is refused.
        let mut short = vec![0u8; 599];
        assert!(decompress(&frame, &mut short, &mut Vec::new()).is_err());
        for cut in [0, 10, 16, 20, 30, 200, frame.len() - 1] {
            assert!(decompress(&frame[..cut], &mut out, &mut Vec::new()).is_err(), "cut at {cut}");
        }
    }

    #[test]
    fn lz4_split_decodes_and_a_longer_one_is_refused() {
        let data: Vec<u8> = (0..64u32).map(|i| (i % 5) as u8).collect();
        let packed = lz4_flex::block::compress(&data);
        let mut frame = header(1 << 5, 1, 64, 64, (16 + 4 + 4 + packed.len()) as u32);
        frame.extend(20u32.to_le_bytes());
        frame.extend((packed.len() as i32).to_le_bytes());
        frame.extend(&packed);
        let mut out = vec![0u8; 64];
        assert!(decompress(&frame, &mut out, &mut Vec::new()).is_ok());
        assert_eq!(out, data);
        // Declared 32 bytes: the same lz4 data would write 64.
        let mut frame32 = frame.clone();
        frame32[4..8].copy_from_slice(&32u32.to_le_bytes());
        frame32[8..12].copy_from_slice(&32u32.to_le_bytes());
        let mut out32 = vec![0u8; 32];
        assert!(decompress(&frame32, &mut out32, &mut Vec::new()).is_err());
    }

    #[test]
    fn other_codecs_are_refused_by_name() {
        for (code, name) in [(0u8, "blosclz"), (2, "snappy"), (4, "zstd")] {
            let mut frame = header(code << 5, 4, 16, 16, 16 + 4 + 4 + 16);
            frame.extend(20u32.to_le_bytes());
            frame.extend([0u8; 20]);
            let e = decompress(&frame, &mut [0u8; 16], &mut Vec::new())
                .err()
                .map(|f| f.into_error(crate::error::Ctx::new(std::path::Path::new("x.vdb"), "VDB")));
            assert!(e.is_some_and(|e| e.to_string().contains(name)));
        }
    }
}
