//! [`VolumeReader`]: a parsed header and a stream positioned at the first sample. Whole volumes
//! are read straight into the grid's storage ([`VolumeReader::read_grid`], one buffer, no copy);
//! out-of-core extraction reads one z-slab at a time ([`VolumeReader::read_slab`]).

use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use isoforge::grid::{as_bytes_mut, AnyGrid, DType, DenseGrid, Lattice, NonFinite, Sample};
use isoforge::walk::Progress;

use super::decode;
use crate::error::{Ctx, Error, Result};
use crate::file::Input;
use crate::limits::Limits;

/// Bytes read between two progress reports.
const PROGRESS_STEP: usize = 16 << 20;

/// How a data block is compressed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Compression {
    None,
    /// gzip members one after another (bgzip-style `.nii.gz`).
    #[cfg(feature = "gzip")]
    Gzip,
    /// One gzip member and nothing after it (NRRD): a second member is trailing data.
    #[cfg(feature = "gzip")]
    GzipOneMember,
    #[cfg(feature = "gzip")]
    Zlib,
}

enum Body {
    /// Binary samples of the file type, in order, x fastest.
    Stream(Box<dyn Read + Send>),
    /// Already decoded (text encodings).
    Grid(AnyGrid),
}

/// An open volume: geometry, sample type and the sample stream.
pub struct VolumeReader {
    path: PathBuf,
    format: &'static str,
    lattice: Lattice,
    file_dtype: DType,
    big_endian: bool,
    /// `slope · v + inter` applied after reading (NIfTI), producing f32 or f64.
    scale: Option<(f64, f64)>,
    compressed: bool,
    /// What the stream is called in messages ("raw data", "gzip data", …).
    what: &'static str,
    body: Body,
    next_k: u32,
}

impl std::fmt::Debug for VolumeReader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VolumeReader")
            .field("path", &self.path)
            .field("format", &self.format)
            .field("lattice", &self.lattice)
            .field("dtype", &self.dtype())
            .finish()
    }
}

impl VolumeReader {
    fn new(ctx: Ctx, lattice: Lattice, file_dtype: DType, big_endian: bool, body: Body) -> Self {
        VolumeReader {
            path: ctx.path.to_path_buf(),
            format: ctx.format,
            lattice,
            file_dtype,
            big_endian,
            scale: None,
            compressed: false,
            what: "data",
            body,
            next_k: 0,
        }
    }

    pub(crate) fn stream(ctx: Ctx, lattice: Lattice, dtype: DType, big_endian: bool, data: StreamSpec) -> Self {
        let mut r = Self::new(ctx, lattice, dtype, big_endian, Body::Stream(data.reader));
        r.compressed = data.compressed;
        r.what = data.what;
        r
    }

    pub(crate) fn decoded(ctx: Ctx, grid: AnyGrid) -> Self {
        Self::new(ctx, grid.lattice().clone(), grid.dtype(), false, Body::Grid(grid))
    }

    pub(crate) fn with_scale(mut self, scale: Option<(f64, f64)>) -> Self {
        self.scale = scale;
        self
    }

    fn ctx(&self) -> Ctx<'_> {
        Ctx::new(&self.path, self.format)
    }

    /// The sampling lattice.
    pub fn lattice(&self) -> &Lattice {
        &self.lattice
    }

    /// The sample type the reader delivers (after NIfTI scaling: f32, or f64 for 32-bit and
    /// double sources).
    pub fn dtype(&self) -> DType {
        match self.scale {
            None => self.file_dtype,
            Some(_) if matches!(self.file_dtype, DType::U32 | DType::I32 | DType::F64) => DType::F64,
            Some(_) => DType::F32,
        }
    }

    /// Bytes the whole volume takes in memory.
    pub fn volume_bytes(&self) -> u64 {
        self.lattice.num_points().saturating_mul(self.dtype().size() as u64)
    }

    /// Whether [`VolumeReader::read_slab`] can deliver the slabs one by one (a binary sample
    /// stream); text encodings are decoded whole when opened.
    pub fn streams(&self) -> bool {
        matches!(self.body, Body::Stream(_))
    }

    /// Reads the whole volume into one grid (checked against `limits` first), rejecting non-finite
    /// samples.
    ///
    /// # Errors
    /// [`Error::Limit`], a truncated or corrupt stream, a non-finite sample.
    pub fn read_grid(self, limits: &Limits) -> Result<AnyGrid> {
        self.read_grid_with_progress(limits, None)
    }

    /// [`VolumeReader::read_grid`], reporting progress per slab.
    ///
    /// # Errors
    /// As [`VolumeReader::read_grid`].
    pub fn read_grid_with_progress(mut self, limits: &Limits, progress: Option<&dyn Progress>) -> Result<AnyGrid> {
        let dims = self.lattice.dims();
        decode::sample_bytes(self.ctx(), dims, self.dtype(), limits)?;
        let grid = match std::mem::replace(&mut self.body, Body::Stream(Box::new(std::io::empty()))) {
            Body::Grid(g) => g,
            Body::Stream(mut r) => {
                let g = isoforge::with_dtype!(self.file_dtype, S => self.read_all::<S>(&mut r, progress)?);
                self.check_trailer(&mut r)?;
                g
            }
        };
        decode::ensure_finite(self.ctx(), grid.first_non_finite())?;
        match self.scale {
            None => Ok(grid),
            Some((slope, inter)) => self.scaled(grid, slope, inter),
        }
    }

    fn read_all<S: Sample>(&self, r: &mut dyn Read, progress: Option<&dyn Progress>) -> Result<AnyGrid>
    where
        AnyGrid: From<DenseGrid<S>>,
    {
        let n = self.lattice.num_points() as usize;
        // Huge pages: fewer faults while reading, fewer TLB misses while extracting.
        let mut data: Vec<S> = isoforge::mesh::huge_vec(n, S::from_f64(0.0));
        self.fill(r, as_bytes_mut(&mut data), 0, progress)?;
        if self.big_endian != cfg!(target_endian = "big") && S::DTYPE.size() > 1 {
            for v in &mut data {
                *v = v.swap_bytes();
            }
        }
        Ok(DenseGrid::new(self.lattice.clone(), data).map_err(|e| self.ctx().lib(e))?.into())
    }

    /// Reads exactly `buf.len()` bytes; `done` bytes of the volume came before.
    fn fill(&self, r: &mut dyn Read, buf: &mut [u8], done: u64, progress: Option<&dyn Progress>) -> Result<()> {
        let total = self.lattice.num_points() * self.file_dtype.size() as u64;
        let mut got = 0;
        let mut reported = 0;
        while got < buf.len() {
            if got - reported >= PROGRESS_STEP {
                reported = got;
                if let Some(p) = progress {
                    p.advance(done + got as u64, total);
                }
            }
            let end = (got + PROGRESS_STEP).min(buf.len());
            match r.read(&mut buf[got..end]) {
                Ok(0) => {
                    return Err(self.ctx().bad(format!(
                        "{} ends after {} of the {total} bytes the header declares (truncated file?)",
                        self.what,
                        done + got as u64
                    )))
                }
                Ok(n) => got += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => {
                    return Err(self.ctx().bad(format!(
                        "{}: corrupt or unreadable after {} bytes: {e}",
                        self.what,
                        done + got as u64
                    )))
                }
            }
        }
        Ok(())
    }

    /// For compressed streams, one more read must reach the end of the stream (verifying its
    /// checksum): more samples than declared are refused like trailing garbage.
    fn check_trailer(&self, r: &mut dyn Read) -> Result<()> {
        if self.compressed {
            match r.read(&mut [0u8; 1]) {
                Ok(0) => {}
                Ok(_) => {
                    let total = self.lattice.num_points().saturating_mul(self.file_dtype.size() as u64);
                    return Err(self.ctx().bad(format!(
                        "{}: the compressed stream holds more than the {total} bytes the header declares",
                        self.what
                    )));
                }
                #[cfg(feature = "gzip")]
                Err(e) if e.get_ref().is_some_and(|inner| inner.is::<TrailingData>()) => {
                    return Err(self.ctx().bad(format!("{}: after its samples, {e}", self.what)))
                }
                Err(e) => {
                    return Err(self
                        .ctx()
                        .bad(format!("{}: the compressed stream is cut or corrupt after its samples: {e}", self.what)))
                }
            }
        }
        Ok(())
    }

    fn scaled(&self, grid: AnyGrid, slope: f64, inter: f64) -> Result<AnyGrid> {
        let lattice = grid.lattice().clone();
        let out: AnyGrid = if self.dtype() == DType::F64 {
            let data: Vec<f64> = grid.values_f64().map(|v| slope * v + inter).collect();
            DenseGrid::new(lattice, data).map_err(|e| self.ctx().lib(e))?.into()
        } else {
            let data: Vec<f32> = grid.values_f64().map(|v| (slope * v + inter) as f32).collect();
            DenseGrid::new(lattice, data).map_err(|e| self.ctx().lib(e))?.into()
        };
        if let Some(nf) = out.first_non_finite() {
            return Err(self
                .ctx()
                .bad(format!("scl_slope {slope} / scl_inter {inter} make sample {:?} non-finite", nf.ijk)));
        }
        Ok(out)
    }

    /// Reads the next z-slab (nx·ny samples, x fastest) into `out`, whose type must be
    /// [`VolumeReader::dtype`].
    ///
    /// # Errors
    /// A truncated or corrupt stream, a non-finite sample, no slab left, a text-encoded volume,
    /// or a mismatched `S`.
    pub fn read_slab<S: Sample>(&mut self, out: &mut [S]) -> Result<()> {
        let [nx, ny, nz] = self.lattice.dims();
        let n = nx as usize * ny as usize;
        if S::DTYPE != self.dtype() || out.len() != n {
            return Err(Error::InvalidInput(format!(
                "read_slab: asked for {} {}, the volume gives {} {}",
                out.len(),
                S::DTYPE,
                n,
                self.dtype()
            )));
        }
        if self.next_k >= nz {
            return Err(self.ctx().bad(format!("no slab {} in a volume of {nz}", self.next_k)));
        }
        let k = self.next_k;
        let mut r = match std::mem::replace(&mut self.body, Body::Stream(Box::new(std::io::empty()))) {
            Body::Stream(r) => r,
            Body::Grid(g) => {
                self.body = Body::Grid(g);
                return Err(self.ctx().unsupported("slab-by-slab reading needs a binary encoding (raw or gzip)"));
            }
        };
        let done = k as u64 * n as u64 * self.file_dtype.size() as u64;
        let result = if self.scale.is_none() {
            self.fill(&mut r, as_bytes_mut(out), done, None).map(|()| {
                if self.big_endian != cfg!(target_endian = "big") && S::DTYPE.size() > 1 {
                    for v in out.iter_mut() {
                        *v = v.swap_bytes();
                    }
                }
            })
        } else {
            let size = self.file_dtype.size();
            let mut bytes = vec![0u8; n * size];
            let (slope, inter) = self.scale.unwrap_or((1.0, 0.0));
            self.fill(&mut r, &mut bytes, done, None).map(|()| {
                isoforge::with_dtype!(self.file_dtype, F => {
                    for (o, c) in out.iter_mut().zip(bytes.chunks_exact(size)) {
                        *o = S::from_f64(slope * F::from_bytes(c, self.big_endian).to_f64() + inter);
                    }
                })
            })
        };
        let result = result.and_then(|()| if k + 1 == nz { self.check_trailer(&mut r) } else { Ok(()) });
        self.body = Body::Stream(r);
        result?;
        let first = isoforge::grid::first_non_finite(out).map(|i| NonFinite {
            ijk: [(i % nx as usize) as u32, (i / nx as usize) as u32, k],
            value: out[i].to_f64(),
        });
        decode::ensure_finite(self.ctx(), first)?;
        self.next_k += 1;
        Ok(())
    }
}

/// Where a reader's samples come from.
pub(crate) struct StreamSpec {
    pub reader: Box<dyn Read + Send>,
    pub compressed: bool,
    pub what: &'static str,
}

/// Opens the regular file `path` at byte `offset`, wrapped in a decompressor; the stream must
/// hold `need` uncompressed bytes, which is checked against the file size at once when
/// uncompressed. No more than `need` bytes (uncompressed) or the rest of the file (compressed)
/// is ever read from it.
pub(crate) fn open_data(
    ctx: Ctx,
    path: &Path,
    offset: u64,
    compression: Compression,
    need: u64,
    what: &'static str,
) -> Result<StreamSpec> {
    let Input { mut file, len } = crate::file::open(ctx, path)?;
    if offset > len {
        return Err(ctx.bad(format!("{what} starts at byte {offset}, past the end of the {len}-byte file")));
    }
    if compression == Compression::None && len - offset < need {
        return Err(ctx.bad(format!(
            "{what} ends after {} of the {need} bytes the header declares (truncated file?)",
            len - offset
        )));
    }
    file.seek(SeekFrom::Start(offset)).map_err(|e| ctx.io(e))?;
    let available = if compression == Compression::None { need } else { len - offset };
    let buffered = BufReader::with_capacity(1 << 20, file.take(available));
    Ok(wrap(buffered, compression, what))
}

/// Wraps a reader in the decompressor for `compression`.
pub(crate) fn wrap<R: std::io::BufRead + Send + 'static>(
    r: R,
    compression: Compression,
    what: &'static str,
) -> StreamSpec {
    let reader: Box<dyn Read + Send> = match compression {
        Compression::None => Box::new(r),
        #[cfg(feature = "gzip")]
        Compression::Gzip => Box::new(flate2::read::MultiGzDecoder::new(r)),
        #[cfg(feature = "gzip")]
        Compression::GzipOneMember => Box::new(OneMember(flate2::bufread::GzDecoder::new(r))),
        #[cfg(feature = "gzip")]
        Compression::Zlib => Box::new(flate2::read::ZlibDecoder::new(r)),
    };
    StreamSpec { reader, compressed: compression != Compression::None, what }
}

/// One gzip member that must end the data: after the member, any byte left (a second member,
/// garbage) is an error rather than the end of the stream.
#[cfg(feature = "gzip")]
struct OneMember<B: std::io::BufRead>(flate2::bufread::GzDecoder<B>);

#[cfg(feature = "gzip")]
impl<B: std::io::BufRead> Read for OneMember<B> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.0.read(buf)?;
        if n == 0 && !buf.is_empty() && !self.0.get_mut().fill_buf()?.is_empty() {
            return Err(std::io::Error::new(std::io::ErrorKind::InvalidData, TrailingData));
        }
        Ok(n)
    }
}

/// The error [`OneMember`] gives when bytes follow its member.
#[cfg(feature = "gzip")]
#[derive(Debug)]
struct TrailingData;

#[cfg(feature = "gzip")]
impl std::fmt::Display for TrailingData {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("bytes follow the end of the gzip stream (a second gzip member or trailing data)")
    }
}

#[cfg(feature = "gzip")]
impl std::error::Error for TrailingData {}

/// Discards `n` bytes of `r` (byte skips after decompression).
pub(crate) fn skip(ctx: Ctx, r: &mut dyn Read, n: u64, what: &str) -> Result<()> {
    let got = std::io::copy(&mut r.take(n), &mut std::io::sink()).map_err(|e| ctx.bad(format!("{what}: {e}")))?;
    if got < n {
        return Err(ctx.bad(format!("{what}: the stream ends within its {n}-byte skip")));
    }
    Ok(())
}

impl<S: Sample> isoforge::volume::SlabSource<S> for VolumeReader {
    fn lattice(&self) -> &Lattice {
        &self.lattice
    }
    fn read_slab(&mut self, out: &mut [S]) -> std::result::Result<(), isoforge::mesh::ExternalError> {
        VolumeReader::read_slab(self, out).map_err(Into::into)
    }
}

impl isoforge::pipeline::AnySlabSource for VolumeReader {
    fn dtype(&self) -> DType {
        VolumeReader::dtype(self)
    }
}
