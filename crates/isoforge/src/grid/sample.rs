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
}

macro_rules! impl_sample {
    ($t:ty, $d:ident, $n:expr, $finite:expr) => {
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
            fn is_finite(self) -> bool {
                let finite: fn($t) -> bool = $finite;
                finite(self)
            }
        }
    };
}

impl_sample!(u8, U8, 1, |_| true);
impl_sample!(i8, I8, 1, |_| true);
impl_sample!(u16, U16, 2, |_| true);
impl_sample!(i16, I16, 2, |_| true);
impl_sample!(u32, U32, 4, |_| true);
impl_sample!(i32, I32, 4, |_| true);
impl_sample!(f32, F32, 4, |v| v.is_finite());
impl_sample!(f64, F64, 8, |v| v.is_finite());
