use std::fmt;

/// The storage type of a sampled grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum DType {
    /// Unsigned 8-bit integer.
    U8,
    /// Signed 8-bit integer.
    I8,
    /// Unsigned 16-bit integer.
    U16,
    /// Signed 16-bit integer.
    I16,
    /// Unsigned 32-bit integer.
    U32,
    /// Signed 32-bit integer.
    I32,
    /// 32-bit IEEE float.
    F32,
    /// 64-bit IEEE float.
    F64,
}

impl DType {
    /// Every supported type.
    pub const ALL: [DType; 8] =
        [DType::U8, DType::I8, DType::U16, DType::I16, DType::U32, DType::I32, DType::F32, DType::F64];

    /// Bytes per sample.
    pub const fn size(self) -> usize {
        match self {
            DType::U8 | DType::I8 => 1,
            DType::U16 | DType::I16 => 2,
            DType::U32 | DType::I32 | DType::F32 => 4,
            DType::F64 => 8,
        }
    }

    /// The short name used on the command line and in reports (`u8`, `f32`, …).
    pub const fn name(self) -> &'static str {
        match self {
            DType::U8 => "u8",
            DType::I8 => "i8",
            DType::U16 => "u16",
            DType::I16 => "i16",
            DType::U32 => "u32",
            DType::I32 => "i32",
            DType::F32 => "f32",
            DType::F64 => "f64",
        }
    }

    /// Parses a short name (`u8`, `int16`, `float`, …); `None` when unknown.
    pub fn parse(s: &str) -> Option<DType> {
        Some(match s.to_ascii_lowercase().as_str() {
            "u8" | "uint8" | "uchar" => DType::U8,
            "i8" | "int8" | "char" => DType::I8,
            "u16" | "uint16" | "ushort" => DType::U16,
            "i16" | "int16" | "short" => DType::I16,
            "u32" | "uint32" | "uint" => DType::U32,
            "i32" | "int32" | "int" => DType::I32,
            "f32" | "float32" | "float" => DType::F32,
            "f64" | "float64" | "double" => DType::F64,
            _ => return None,
        })
    }

    /// True for the two float types.
    pub const fn is_float(self) -> bool {
        matches!(self, DType::F32 | DType::F64)
    }
}

impl fmt::Display for DType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

mod sealed {
    pub trait Sealed {}
}

/// A sample type of a dense grid. Values convert to `f64` exactly, so classification against an
/// `f64` iso is exact in the sample's own type.
pub trait Sample: Copy + Send + Sync + PartialOrd + fmt::Debug + sealed::Sealed + 'static {
    /// The matching [`DType`].
    const DTYPE: DType;
    /// Exact conversion to `f64`.
    fn to_f64(self) -> f64;
    /// Decodes one sample from little- or big-endian bytes (`bytes.len() == DTYPE.size()`).
    fn from_bytes(bytes: &[u8], big_endian: bool) -> Self;
    /// False for NaN and infinities (always true for integers).
    #[inline]
    fn is_finite(self) -> bool {
        true
    }
    /// The sample with its bytes reversed (endianness conversion).
    fn swap_bytes(self) -> Self;
    /// Conversion from `f64` (`as` semantics: saturating for integers).
    fn from_f64(v: f64) -> Self;
    /// The native-type test equivalent to `v < iso` (`below`) or `v > iso` (`!below`) for every
    /// finite sample `v`, with `iso` an `f64`.
    fn threshold(iso: f64, below: bool) -> Threshold<Self>;
}

/// A native-type inside test: see [`Sample::threshold`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Threshold<S> {
    /// Inside ⇔ `v < t`.
    Less(S),
    /// Inside ⇔ `v > t`.
    Greater(S),
    /// Every value is inside.
    All,
    /// No value is inside.
    None,
}

impl<S: PartialOrd + Copy> Threshold<S> {
    /// Whether `v` is inside.
    #[inline(always)]
    pub fn inside(self, v: S) -> bool {
        match self {
            Threshold::Less(t) => v < t,
            Threshold::Greater(t) => v > t,
            Threshold::All => true,
            Threshold::None => false,
        }
    }
}

/// The index of the first NaN or infinite sample, if any (never for integer samples).
pub fn first_non_finite<S: Sample>(samples: &[S]) -> Option<usize> {
    // Blocks tested without an early exit (a loop the compiler vectorises), then the first
    // failing block searched: a scan at memory speed.
    const BLOCK: usize = 256;
    let (b, block) =
        samples.chunks(BLOCK).enumerate().find(|(_, c)| !c.iter().fold(true, |ok, v| ok & v.is_finite()))?;
    Some(b * BLOCK + block.iter().position(|v| !v.is_finite())?)
}

/// Views samples as bytes, to read files straight into a grid's storage.
pub fn as_bytes_mut<S: Sample>(samples: &mut [S]) -> &mut [u8] {
    let len = std::mem::size_of_val(samples);
    // SAFETY: `Sample` is sealed to the primitive integer and float types, which have no padding
    // and for which every bit pattern is a valid value; `u8` has alignment 1 and the length is the
    // slice's size in bytes, so the byte view covers exactly the same memory.
    unsafe { std::slice::from_raw_parts_mut(samples.as_mut_ptr().cast::<u8>(), len) }
}

/// Views samples as bytes (native byte order), to write them to files.
pub fn as_bytes<S: Sample>(samples: &[S]) -> &[u8] {
    let len = std::mem::size_of_val(samples);
    // SAFETY: as for `as_bytes_mut`: primitive types without padding, alignment 1 for `u8`, the
    // same memory and length, read-only.
    unsafe { std::slice::from_raw_parts(samples.as_ptr().cast::<u8>(), len) }
}

macro_rules! impl_int {
    ($t:ty, $d:ident, $n:expr) => {
        impl sealed::Sealed for $t {}
        impl Sample for $t {
            const DTYPE: DType = DType::$d;
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn from_bytes(bytes: &[u8], big_endian: bool) -> Self {
                let mut b = [0u8; $n];
                b.copy_from_slice(&bytes[..$n]);
                if big_endian {
                    <$t>::from_be_bytes(b)
                } else {
                    <$t>::from_le_bytes(b)
                }
            }
            #[inline]
            fn swap_bytes(self) -> Self {
                <$t>::swap_bytes(self)
            }
            #[inline]
            fn from_f64(v: f64) -> Self {
                v as $t
            }
            fn threshold(iso: f64, below: bool) -> Threshold<Self> {
                let (min, max) = (<$t>::MIN as f64, <$t>::MAX as f64);
                if below {
                    // v < iso ⇔ v < ceil(iso) for integers.
                    let c = iso.ceil();
                    if c > max {
                        Threshold::All
                    } else if c <= min {
                        Threshold::None
                    } else {
                        Threshold::Less(c as $t)
                    }
                } else {
                    // v > iso ⇔ v > floor(iso).
                    let f = iso.floor();
                    if f < min {
                        Threshold::All
                    } else if f >= max {
                        Threshold::None
                    } else {
                        Threshold::Greater(f as $t)
                    }
                }
            }
        }
    };
}

impl_int!(u8, U8, 1);
impl_int!(i8, I8, 1);
impl_int!(u16, U16, 2);
impl_int!(i16, I16, 2);
impl_int!(u32, U32, 4);
impl_int!(i32, I32, 4);

impl sealed::Sealed for f32 {}
impl Sample for f32 {
    const DTYPE: DType = DType::F32;
    #[inline]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline]
    fn from_bytes(bytes: &[u8], big_endian: bool) -> Self {
        let b = [bytes[0], bytes[1], bytes[2], bytes[3]];
        if big_endian {
            f32::from_be_bytes(b)
        } else {
            f32::from_le_bytes(b)
        }
    }
    #[inline]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
    #[inline]
    fn swap_bytes(self) -> Self {
        f32::from_bits(self.to_bits().swap_bytes())
    }
    #[inline]
    fn from_f64(v: f64) -> Self {
        v as f32
    }
    fn threshold(iso: f64, below: bool) -> Threshold<Self> {
        // The nearest f32 on the right side of iso: v < iso ⇔ v < t with t the smallest f32 ≥ iso
        // (v > iso ⇔ v > t with t the largest f32 ≤ iso).
        let t = iso as f32;
        if below {
            Threshold::Less(if (t as f64) < iso { t.next_up() } else { t })
        } else {
            Threshold::Greater(if (t as f64) > iso { t.next_down() } else { t })
        }
    }
}

impl sealed::Sealed for f64 {}
impl Sample for f64 {
    const DTYPE: DType = DType::F64;
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline]
    fn from_bytes(bytes: &[u8], big_endian: bool) -> Self {
        let mut b = [0u8; 8];
        b.copy_from_slice(&bytes[..8]);
        if big_endian {
            f64::from_be_bytes(b)
        } else {
            f64::from_le_bytes(b)
        }
    }
    #[inline]
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
    #[inline]
    fn swap_bytes(self) -> Self {
        f64::from_bits(self.to_bits().swap_bytes())
    }
    #[inline]
    fn from_f64(v: f64) -> Self {
        v
    }
    fn threshold(iso: f64, below: bool) -> Threshold<Self> {
        if below {
            Threshold::Less(iso)
        } else {
            Threshold::Greater(iso)
        }
    }
}
