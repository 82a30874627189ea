//! Issue 10, hardening of the readers: non-regular files refused and reads bounded (item 2),
//! declared sizes checked before decoding (3), declared counts bounded before looping (4),
//! nonsense geometry refused naming the file, the field and the value (7).
#![cfg(unix)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

use isoforge_io::{read_mesh, read_volume, Limits, MeshFormat};

fn testdata() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata")
}

/// Reads `path` as a mesh or a volume by extension, on a thread that must finish within
/// `secs` (an unbounded read or an endless loop fails the test instead of hanging it).
fn read_within(path: &Path, limits: Limits, secs: u64) -> Result<(), String> {
    let (tx, rx) = mpsc::channel();
    let p = path.to_path_buf();
    std::thread::spawn(move || {
        let r = if MeshFormat::from_path(&p).is_some() && isoforge_io::VolumeFormat::from_path(&p).is_none() {
            read_mesh(&p, &limits).map(|_| ())
        } else {
            read_volume(&p, &limits).map(|_| ())
        };
        let _ = tx.send(r.map_err(|e| e.to_string()));
    });
    rx.recv_timeout(Duration::from_secs(secs))
        .unwrap_or_else(|_| panic!("{}: reading did not finish within {secs} s", path.display()))
}

fn err(path: &Path, limits: Limits) -> String {
    match read_within(path, limits, 30) {
        Ok(()) => panic!("{}: read without error", path.display()),
        Err(e) => {
            assert!(!e.contains('\n'), "not one line: {e}");
            e
        }
    }
}

fn small() -> Limits {
    Limits::new(1 << 20)
}

/// Issue 10 item 2: a 90-byte .nhdr whose data file is /dev/zero (raw and ASCII) read forever.
#[test]
fn issue_10_detached_data_on_a_device_or_fifo_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.raw");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    for encoding in ["raw", "ascii", "gzip"] {
        for (data, kind) in [("/dev/zero", "a character device"), (fifo.to_str().unwrap(), "a FIFO")] {
            let h = dir.path().join(format!("z-{encoding}.nhdr"));
            let header = format!(
                "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 100 100 100\nencoding: {encoding}\ndata file: {data}\n\n"
            );
            std::fs::write(&h, header).unwrap();
            let e = err(&h, Limits::default());
            assert!(e.starts_with(&format!("{data}: is {kind}")), "{encoding}: {e}");
        }
    }
    // MetaImage and NIfTI .hdr/.img pairs too.
    let mhd = dir.path().join("z.mhd");
    std::fs::write(&mhd, "NDims = 3\nDimSize = 10 10 10\nElementType = MET_UCHAR\nElementDataFile = pipe.raw\n")
        .unwrap();
    assert!(err(&mhd, Limits::default()).contains("a FIFO (named pipe), not a regular file"));
}

/// Issue 10 item 2: a .ply that is a symlink to /dev/zero read forever; every format refuses.
#[test]
fn issue_10_symlinks_to_devices_are_refused_for_every_format() {
    let dir = tempfile::tempdir().unwrap();
    let names = [
        "z.ply", "z.obj", "z.stl", "z.off", "z.nrrd", "z.nhdr", "z.nii", "z.nii.gz", "z.hdr", "z.mha", "z.mhd",
        "z.mrc", "z.vtk", "z.vti", "z.png", "z.tif",
    ];
    for name in names {
        let p = dir.path().join(name);
        std::os::unix::fs::symlink("/dev/zero", &p).unwrap();
        let e = err(&p, Limits::default());
        assert!(e.contains("is a character device, not a regular file"), "{name}: {e}");
        assert!(e.starts_with(&p.display().to_string()), "{name}: {e}");
    }
}

/// Issue 10 item 2: a folder where a file is expected names the folder.
#[test]
fn issue_10_a_folder_given_as_a_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["m.ply", "m.obj", "m.stl", "m.off"] {
        let p = dir.path().join(name);
        std::fs::create_dir(&p).unwrap();
        let e = err(&p, Limits::default());
        assert_eq!(e, format!("{}: is a folder, where a file is expected", p.display()));
    }
    // A folder given as a volume is a DICOM series or numbered slices, by design.
    let v = dir.path().join("v.nrrd");
    std::fs::create_dir(&v).unwrap();
    assert_eq!(err(&v, Limits::default()), format!("{}: no DICOM image in the folder", v.display()));
    // A NIfTI whose .img is a folder.
    let hdr = dir.path().join("pair.hdr");
    std::fs::write(&hdr, nifti_header([2, 2, 2], [1.0; 4], 0, 0, None, b"ni1\0")).unwrap();
    std::fs::create_dir(dir.path().join("pair.img")).unwrap();
    assert!(err(&hdr, Limits::default()).ends_with("pair.img: is a folder, where a file is expected"));
}

/// Issue 10 item 4: `element junk 18446744073709551615` before the vertex element looped forever.
#[test]
fn issue_10_ply_counts_are_bounded_before_looping() {
    let dir = tempfile::tempdir().unwrap();
    // A valid binary body: three vertices and one triangle.
    let mut binary = Vec::new();
    for v in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
        v.iter().for_each(|c| binary.extend_from_slice(&c.to_le_bytes()));
    }
    binary.push(3);
    [0i32, 1, 2].iter().for_each(|i| binary.extend_from_slice(&i.to_le_bytes()));
    let tail = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    let cases: [(&str, String, &[u8]); 4] = [
        (
            "empty_ascii",
            format!("ply\nformat ascii 1.0\nelement junk 18446744073709551615\n{tail}"),
            b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        ),
        (
            "empty_binary",
            format!("ply\nformat binary_little_endian 1.0\nelement junk 18446744073709551615\n{tail}"),
            &binary,
        ),
        (
            "prop_ascii",
            format!("ply\nformat ascii 1.0\nelement junk 18446744073709551615\nproperty uchar a\n{tail}"),
            b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        ),
        (
            "list_binary",
            format!("ply\nformat binary_little_endian 1.0\nelement junk 4294967296\nproperty list uchar int a\n{tail}"),
            &binary,
        ),
    ];
    for (name, header, body) in cases {
        let p = dir.path().join(format!("{name}.ply"));
        let mut bytes = header.into_bytes();
        bytes.extend_from_slice(body);
        std::fs::write(&p, bytes).unwrap();
        let r = read_within(&p, Limits::default(), 10);
        if name.starts_with("empty") {
            // Instances without properties take no bytes: the mesh reads, instantly.
            assert!(r.is_ok(), "{name}: {r:?}");
        } else {
            let e = r.unwrap_err();
            assert!(e.contains("element counts need at least"), "{name}: {e}");
        }
    }
}

/// Issue 10 items 3 and 4: polygons and vertices cannot grow a mesh past the limit, whatever
/// the header's face count says (or, for OBJ, without any count).
#[test]
fn issue_10_meshes_cannot_grow_past_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let limits = Limits::new(64 << 10);
    // One PLY face with 20000 corners: 19998 triangles (240 KB) from a 40 KB body.
    let p = dir.path().join("fan.ply");
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list int ushort vertex_indices\nend_header\n".to_vec();
    for v in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
        v.iter().for_each(|c| b.extend_from_slice(&c.to_le_bytes()));
    }
    b.extend_from_slice(&20000i32.to_le_bytes());
    (0..20000u32).for_each(|i| b.extend_from_slice(&((i % 3) as u16).to_le_bytes()));
    std::fs::write(&p, &b).unwrap();
    assert!(err(&p, limits).contains("over the limit of 65536 bytes"));
    // OBJ: faces without a count.
    let p = dir.path().join("fan.obj");
    let mut text = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    for _ in 0..6000 {
        text.push_str("f 1 2 3\n");
    }
    std::fs::write(&p, text).unwrap();
    assert!(err(&p, limits).contains("over the limit"));
    // OFF: a face line longer than its count promises nothing more; a huge polygon is refused.
    let p = dir.path().join("fan.off");
    let mut text = String::from("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n10000");
    for i in 0..10000 {
        text.push_str(&format!(" {}", i % 3));
    }
    std::fs::write(&p, text + "\n").unwrap();
    assert!(err(&p, limits).contains("over the limit"));
}

/// A minimal single-slice DICOM file (explicit VR little endian) written by dicom-rs.
fn dicom_slice(extra_private: bool, pixel_spacing: &str) -> Vec<u8> {
    use dicom_core::{DataElement, PrimitiveValue, Tag, VR};
    use dicom_dictionary_std::tags;
    let mut obj = dicom_object::InMemDicomObject::new_empty();
    let mut put = |tag, vr, value: PrimitiveValue| {
        obj.put(DataElement::new(tag, vr, value));
    };
    put(tags::SOP_CLASS_UID, VR::UI, PrimitiveValue::from("1.2.840.10008.5.1.4.1.1.2"));
    put(tags::SOP_INSTANCE_UID, VR::UI, PrimitiveValue::from("1.2.3.4.1"));
    put(tags::SERIES_INSTANCE_UID, VR::UI, PrimitiveValue::from("1.2.3.4"));
    put(tags::ROWS, VR::US, PrimitiveValue::from(2u16));
    put(tags::COLUMNS, VR::US, PrimitiveValue::from(2u16));
    put(tags::SAMPLES_PER_PIXEL, VR::US, PrimitiveValue::from(1u16));
    put(tags::PHOTOMETRIC_INTERPRETATION, VR::CS, PrimitiveValue::from("MONOCHROME2"));
    put(tags::BITS_ALLOCATED, VR::US, PrimitiveValue::from(16u16));
    put(tags::BITS_STORED, VR::US, PrimitiveValue::from(16u16));
    put(tags::HIGH_BIT, VR::US, PrimitiveValue::from(15u16));
    put(tags::PIXEL_REPRESENTATION, VR::US, PrimitiveValue::from(1u16));
    put(tags::PIXEL_SPACING, VR::DS, PrimitiveValue::from(pixel_spacing));
    put(tags::IMAGE_POSITION_PATIENT, VR::DS, PrimitiveValue::from("0\\0\\0"));
    put(tags::IMAGE_ORIENTATION_PATIENT, VR::DS, PrimitiveValue::from("1\\0\\0\\0\\1\\0"));
    if extra_private {
        put(Tag(0x0009, 0x1010), VR::OB, PrimitiveValue::from(vec![7u8; 8]));
    }
    put(tags::PIXEL_DATA, VR::OW, PrimitiveValue::from(vec![1u8; 8]));
    let file = obj.with_meta(dicom_object::FileMetaTableBuilder::new().transfer_syntax("1.2.840.10008.1.2.1")).unwrap();
    let mut bytes = Vec::new();
    file.write_all(&mut bytes).unwrap();
    bytes
}

/// Sets the 4-byte length of the first element whose header starts with `header` to `len`, and
/// cuts the file a few bytes after it.
fn patch_length(bytes: &[u8], header: &[u8], len: u32) -> Vec<u8> {
    let at = bytes.windows(header.len()).position(|w| w == header).expect("element present");
    let mut out = bytes[..at + header.len() + 4 + 8.min(bytes.len() - at - header.len() - 4)].to_vec();
    out[at + header.len()..at + header.len() + 4].copy_from_slice(&len.to_le_bytes());
    out
}

/// Issue 10 item 3: a 566-byte DICOM slice declaring a 4 GiB pixel data element reached 4.2 GB.
/// The guard refuses the length before the parser allocates (the memory itself is measured in
/// tests/memory.rs).
#[test]
fn issue_10_dicom_lengths_beyond_the_file_are_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let good = dicom_slice(true, "0.8\\0.7");
    for (name, header) in [
        ("pixels", &[0xE0, 0x7F, 0x10, 0x00, b'O', b'W', 0, 0][..]),
        ("private", &[0x09, 0x00, 0x10, 0x10, b'O', b'B', 0, 0][..]),
    ] {
        let series = dir.path().join(name);
        std::fs::create_dir(&series).unwrap();
        let bytes = patch_length(&good, header, 0xFFFF_FFFE);
        assert!(bytes.len() < 700, "{}", bytes.len());
        std::fs::write(series.join("slice.dcm"), &bytes).unwrap();
        let e = err(&series, small());
        assert!(e.contains("slice.dcm: damaged DICOM file: element ("), "{e}");
        assert!(e.contains("declares 4294967294 bytes, only"), "{e}");
    }
    // The unpatched file reads.
    let ok = dir.path().join("ok");
    std::fs::create_dir(&ok).unwrap();
    std::fs::write(ok.join("slice.dcm"), &good).unwrap();
    assert!(read_within(&ok, small(), 10).is_ok());
    // A slice file larger than the limit allows is refused before it is read into memory.
    let big = dir.path().join("big");
    std::fs::create_dir(&big).unwrap();
    let mut padded = good.clone();
    padded.resize(3 << 20, 0);
    std::fs::write(big.join("slice.dcm"), &padded).unwrap();
    assert!(err(&big, small()).contains("the file needs 3145728 bytes, over the limit"));
}

fn png_chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_be_bytes());
    let mut crc = flate2::Crc::new();
    crc.update(kind);
    crc.update(data);
    out.extend_from_slice(kind);
    out.extend_from_slice(data);
    out.extend_from_slice(&crc.sum().to_be_bytes());
}

/// A greyscale PNG header of `w` x `h` followed by one zlib-compressed zero row.
fn png_header_only(w: u32, h: u32) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
    png_chunk(&mut out, b"IHDR", &ihdr);
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
    z.write_all(&vec![0u8; w as usize + 1]).unwrap();
    png_chunk(&mut out, b"IDAT", &z.finish().unwrap());
    png_chunk(&mut out, b"IEND", &[]);
    out
}

/// A little-endian TIFF of `pages` uncompressed 8-bit greyscale pages of `w` x `h` whose strips
/// point past the end (only the headers matter).
fn tiff_header_only(w: u32, h: u32, pages: u32) -> Vec<u8> {
    let mut out = b"II*\0".to_vec();
    out.extend_from_slice(&8u32.to_le_bytes());
    let entries: u16 = 8;
    let ifd_size = 2 + 12 * entries as u32 + 4;
    for p in 0..pages {
        let next = if p + 1 < pages { 8 + (p + 1) * ifd_size } else { 0 };
        out.extend_from_slice(&entries.to_le_bytes());
        for (tag, typ, value) in [
            (256u16, 4u16, w),
            (257, 4, h),
            (258, 3, 8),
            (259, 3, 1),
            (262, 3, 1),
            (273, 4, 1 << 20),
            (278, 4, h),
            (279, 4, w.saturating_mul(h)),
        ] {
            out.extend_from_slice(&tag.to_le_bytes());
            out.extend_from_slice(&typ.to_le_bytes());
            out.extend_from_slice(&1u32.to_le_bytes());
            out.extend_from_slice(&value.to_le_bytes());
        }
        out.extend_from_slice(&next.to_le_bytes());
    }
    out
}

/// Issue 10 item 3: an 854 KB PNG of 30000 x 30000 was decoded whatever --max-bytes said;
/// image sizes (all pages of a TIFF) are checked before any pixel is decoded.
#[test]
fn issue_10_image_sizes_are_checked_before_decoding() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("huge.png");
    std::fs::write(&p, png_header_only(30000, 30000)).unwrap();
    let e = err(&p, small());
    assert!(e.contains("30000 x 30000 image needs 900000000 bytes, over the limit of 1048576"), "{e}");
    let t = dir.path().join("huge.tif");
    std::fs::write(&t, tiff_header_only(60000, 60000, 1)).unwrap();
    assert!(err(&t, small()).contains("60000 x 60000 x 1 pages needs 3600000000 bytes"));
    // Three pages of 600 x 600 fit one by one, not together: refused before the first decodes.
    std::fs::write(&t, tiff_header_only(600, 600, 3)).unwrap();
    assert!(err(&t, small()).contains("600 x 600 x 3 pages needs 1080000 bytes"));
}

/// A NIfTI-1 header (u8 samples, `dims` points) with `pixdim`, the codes, and an sform, followed
/// by the samples when `magic` is "n+1".
fn nifti_header(
    dims: [i16; 3],
    pixdim: [f32; 4],
    qcode: i16,
    scode: i16,
    srow: Option<[[f32; 4]; 3]>,
    magic: &[u8; 4],
) -> Vec<u8> {
    let mut h = vec![0u8; 352];
    let put16 = |h: &mut Vec<u8>, at: usize, v: i16| h[at..at + 2].copy_from_slice(&v.to_le_bytes());
    let put32 = |h: &mut Vec<u8>, at: usize, v: f32| h[at..at + 4].copy_from_slice(&v.to_le_bytes());
    h[0..4].copy_from_slice(&348i32.to_le_bytes());
    put16(&mut h, 40, 3);
    for a in 0..3 {
        put16(&mut h, 42 + 2 * a, dims[a]);
    }
    put16(&mut h, 70, 2);
    put16(&mut h, 72, 8);
    for (i, v) in pixdim.iter().enumerate() {
        put32(&mut h, 76 + 4 * i, *v);
    }
    put32(&mut h, 108, if magic == b"n+1\0" { 352.0 } else { 0.0 });
    put16(&mut h, 252, qcode);
    put16(&mut h, 254, scode);
    if let Some(rows) = srow {
        for (r, row) in rows.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                put32(&mut h, 280 + 16 * r + 4 * c, *v);
            }
        }
    }
    h[344..348].copy_from_slice(magic);
    if magic == b"n+1\0" {
        let n = dims.iter().map(|&d| d as usize).product::<usize>();
        h.extend((0..n).map(|i| i as u8));
    }
    h
}

/// An MRC map (mode 0, int8) with cell lengths `cell`, sampling `m` and `origin`.
fn mrc(dims: [i32; 3], m: [i32; 3], cell: [f32; 3], origin: [f32; 3]) -> Vec<u8> {
    let mut h = vec![0u8; 1024];
    let i32_at = |h: &mut Vec<u8>, at: usize, v: i32| h[at..at + 4].copy_from_slice(&v.to_le_bytes());
    let f32_at = |h: &mut Vec<u8>, at: usize, v: f32| h[at..at + 4].copy_from_slice(&v.to_le_bytes());
    for a in 0..3 {
        i32_at(&mut h, 4 * a, dims[a]);
        i32_at(&mut h, 28 + 4 * a, m[a]);
        f32_at(&mut h, 40 + 4 * a, cell[a]);
        i32_at(&mut h, 64 + 4 * a, a as i32 + 1);
        f32_at(&mut h, 196 + 4 * a, origin[a]);
    }
    h[208..212].copy_from_slice(b"MAP ");
    h[212] = 0x44;
    h[213] = 0x44;
    h.extend(std::iter::repeat_n(1u8, dims.iter().map(|&d| d as usize).product()));
    h
}

fn nrrd(fields: &str) -> String {
    format!("NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: ascii\n{fields}\n\n0 1 2 3 4 5 6 7\n")
}

fn vti(image_attrs: &str) -> String {
    format!(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\">\n<ImageData WholeExtent=\"0 1 0 1 0 1\" {image_attrs}>\n<Piece Extent=\"0 1 0 1 0 1\">\n<PointData Scalars=\"v\">\n<DataArray type=\"UInt8\" Name=\"v\" format=\"ascii\">0 1 2 3 4 5 6 7</DataArray>\n</PointData>\n</Piece>\n</ImageData>\n</VTKFile>\n"
    )
}

/// Issue 10 item 7: spacing 1e308 gave inf vertices and exit 0; NaN/inf/0/negative spacings
/// were replaced by 1 or made positive. Each reader now names the file, the field and the value.
#[test]
fn issue_10_nonsense_geometry_is_refused_naming_file_field_and_value() {
    let dir = tempfile::tempdir().unwrap();
    let check = |name: &str, bytes: &[u8], needles: &[&str]| {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        let e = err(&p, Limits::default());
        assert!(e.starts_with(&p.display().to_string()), "{name}: {e}");
        for n in needles {
            assert!(e.contains(n), "{name}: expected {n:?} in {e}");
        }
    };
    // NRRD: spacings and space directions.
    check("huge.nrrd", nrrd("spacings: 1e308 1 1").as_bytes(), &["line 6: spacings: lattice of 2x2x2 points", "reach"]);
    check(
        "neg.nrrd",
        nrrd("spacings: -1 1 1").as_bytes(),
        &["line 6: spacings [-1.0, 1.0, 1.0]: the spacing of axis 0 is -1"],
    );
    check("zero.nrrd", nrrd("spacings: 1 0 1").as_bytes(), &["spacings [1.0, 0.0, 1.0]: the spacing of axis 1 is 0"]);
    check("inf.nrrd", nrrd("spacings: 1 1 inf").as_bytes(), &["the spacing of axis 2 is inf"]);
    check(
        "dirs.nrrd",
        nrrd("space: RAS\nspace directions: (1e308,0,0) (0,1,0) (0,0,1)").as_bytes(),
        &["line 7: space directions: lattice of 2x2x2 points, spacing [1e308, 1.0, 1.0]", "reach"],
    );
    check(
        "origin.nrrd",
        nrrd("space: RAS\nspace directions: (3e38,0,0) (0,1,0) (0,0,1)\nspace origin: (3e38,0,0)").as_bytes(),
        &["line 7: space directions, line 8: space origin: lattice", "reach 6.00e38"],
    );
    // NIfTI: pixdim in the qform and pixdim methods, huge sform axes.
    check(
        "q.nii",
        &nifti_header([2, 2, 2], [1.0, -1.5, 1.0, 1.0], 1, 0, None, b"n+1\0"),
        &["pixdim[1] = -1.5: voxel sizes must be finite and positive"],
    );
    check("q0.nii", &nifti_header([2, 2, 2], [1.0, 1.0, 0.0, 1.0], 1, 0, None, b"n+1\0"), &["pixdim[2] = 0"]);
    check("qnan.nii", &nifti_header([2, 2, 2], [1.0, 1.0, 1.0, f32::NAN], 0, 0, None, b"n+1\0"), &["pixdim[3] = NaN"]);
    let huge = [[3e38, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 3e38]];
    check("s.nii", &nifti_header([2, 2, 2], [1.0; 4], 0, 1, Some(huge), b"n+1\0"), &["sform: lattice", "reach"]);
    // MetaImage, VTK, VTI, MRC.
    check(
        "m.mha",
        b"NDims = 3\nDimSize = 2 2 2\nElementSpacing = 1e308 1 1\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n\0\x01\x02\x03\x04\x05\x06\x07",
        &["ElementSpacing, Offset, TransformMatrix: lattice", "reach 1.00e308"],
    );
    check(
        "v.vtk",
        b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\nSPACING 1e308 1 1\nORIGIN 0 0 0\nPOINT_DATA 8\nSCALARS v unsigned_char 1\nLOOKUP_TABLE default\n0 1 2 3 4 5 6 7\n",
        &["SPACING, ORIGIN: lattice", "reach 1.00e308"],
    );
    check(
        "neg.vti",
        vti("Spacing=\"-1 1 1\"").as_bytes(),
        &["ImageData Spacing [-1.0, 1.0, 1.0]: the spacing of axis 0 is -1"],
    );
    check("nan.vti", vti("Spacing=\"nan 1 1\"").as_bytes(), &["Spacing \"nan 1 1\": expected 3 finite numbers"]);
    check("origin.vti", vti("Origin=\"0 x 0\"").as_bytes(), &["Origin \"0 x 0\": expected 3 finite numbers"]);
    check(
        "cell.mrc",
        &mrc([2, 2, 2], [2, 2, 2], [-4.0, 2.0, 2.0], [0.0; 3]),
        &["CELLA.X = -4: cell lengths must be finite and positive"],
    );
    check("m0.mrc", &mrc([2, 2, 2], [0, 2, 2], [4.0, 2.0, 2.0], [0.0; 3]), &["MX = 0 with CELLA.X = 4"]);
    check(
        "o.mrc",
        &mrc([2, 2, 2], [2, 2, 2], [2.0; 3], [f32::INFINITY, 0.0, 0.0]),
        &["ORIGIN [inf, 0.0, 0.0]: inf is not a finite coordinate"],
    );
    check(
        "big.mrc",
        &mrc([2, 2, 2], [1, 1, 1], [3e38, 3e38, 3e38], [0.0; 3]),
        &["CELLA / MX MY MZ, ORIGIN: lattice", "reach"],
    );
    // A float16 map (MODE 12) with a NaN: the same message as every reader's.
    let mut half = mrc([2, 2, 2], [2, 2, 2], [2.0; 3], [0.0; 3]);
    half[12..16].copy_from_slice(&12i32.to_le_bytes());
    half.truncate(1024);
    for s in 0..8 {
        half.extend_from_slice(&(if s == 5 { 0x7e00u16 } else { 0x3c00 }).to_le_bytes());
    }
    check("half.mrc", &half, &["sample (1, 0, 1) is NaN: volumes must be finite"]);
    // DICOM: PixelSpacing.
    for (name, spacing, needle) in [
        ("dcm_zero", "0\\0.7", "PixelSpacing [0.0, 0.7]: 0 is not a positive distance"),
        ("dcm_huge", "1e300\\0.7", "PixelSpacing, ImagePositionPatient, ImageOrientationPatient: lattice"),
    ] {
        let series = dir.path().join(name);
        std::fs::create_dir(&series).unwrap();
        std::fs::write(series.join("slice.dcm"), dicom_slice(false, spacing)).unwrap();
        let e = err(&series, Limits::default());
        assert!(e.contains(needle), "{name}: {e}");
    }
    // Raw volumes: the caller's spacing.
    let raw = dir.path().join("v.raw");
    std::fs::write(&raw, [0u8; 8]).unwrap();
    let mut spec = isoforge_io::RawSpec::new([2, 2, 2], isoforge::grid::DType::U8);
    spec.spacing = [1e308, 1.0, 1.0];
    let e = isoforge_io::read::raw::read_raw(&raw, &spec, &Limits::default()).unwrap_err().to_string();
    assert!(
        e.starts_with(&raw.display().to_string()) && e.contains("spacing, origin: lattice") && e.contains("reach"),
        "{e}"
    );
    spec.spacing = [1.0, f64::NAN, 1.0];
    let e = isoforge_io::read::raw::read_raw(&raw, &spec, &Limits::default()).unwrap_err().to_string();
    assert!(e.contains("spacing [1.0, NaN, 1.0]: the spacing of axis 1 is NaN"), "{e}");
    // Too many points for any lattice (a streaming open, whose byte limit allows it): the error
    // names the dims, not geometry the caller never gave.
    let spec = isoforge_io::RawSpec::new([2_000_000; 3], isoforge::grid::DType::U8);
    let e = isoforge_io::read::raw::open_raw(&raw, &spec, &Limits::new(u64::MAX)).err().unwrap().to_string();
    assert!(e.contains("dims 2000000x2000000x2000000: lattice points") && !e.contains("spacing"), "{e}");
}

/// Issue 10 item 7: where a format documents a rule it is applied (and the module docs say so).
#[test]
fn issue_10_documented_geometry_rules_apply() {
    let dir = tempfile::tempdir().unwrap();
    let read = |name: &str, bytes: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        read_volume(&p, &Limits::default()).unwrap_or_else(|e| panic!("{name}: {e}"))
    };
    // NRRD: "nan" is an axis without spacing information: unit spacing.
    assert_eq!(read("nan.nrrd", nrrd("spacings: nan 2 3").as_bytes()).lattice().spacing(), [1.0, 2.0, 3.0]);
    // MRC: a cell length of 0 is "not set": unit voxels.
    assert_eq!(
        read("c0.mrc", &mrc([2, 2, 2], [2, 2, 2], [0.0, 3.0, 4.0], [0.0; 3])).lattice().spacing(),
        [1.0, 1.5, 2.0]
    );
    // NIfTI qform: qfac = pixdim[0] = -1 flips the third axis (a mirrored lattice).
    let g = read("qfac.nii", &nifti_header([2, 2, 2], [-1.0, 1.0, 1.0, 2.0], 1, 0, None, b"n+1\0"));
    assert!(g.lattice().is_mirrored());
    assert_eq!(g.lattice().spacing(), [1.0, 1.0, 2.0]);
    assert_eq!(g.lattice().direction()[2], [0.0, 0.0, -1.0]);
    // An axis with a single point has no spacing: 2D images with pixdim[3] = 0 read.
    let g = read("flat.nii", &nifti_header([2, 2, 1], [1.0, 0.5, 0.5, 0.0], 1, 0, None, b"n+1\0"));
    assert_eq!(g.lattice().spacing(), [0.5, 0.5, 1.0]);
}

/// Issue 10 item 6: the files reading a volume opens, for the output checks.
#[test]
fn issue_10_input_files_name_detached_data() {
    let v = testdata().join("volumes");
    let files = isoforge_io::input_files(&v.join("u16_detached.nhdr"));
    assert_eq!(files, [v.join("u16_detached.nhdr"), v.join("u16_detached.raw")]);
    let files = isoforge_io::input_files(&v.join("f64_external.mhd"));
    assert_eq!(files, [v.join("f64_external.mhd"), v.join("f64_external.raw")]);
    assert_eq!(isoforge_io::input_files(&v.join("u8_raw.nrrd")), [v.join("u8_raw.nrrd")]);
    assert_eq!(isoforge_io::input_files(Path::new("x.hdr")), [PathBuf::from("x.hdr"), PathBuf::from("x.img")]);
}

/// Issue 10 item 6: a .gltf's buffer replaces an existing .bin only when that .gltf names it.
#[test]
fn issue_10_gltf_never_replaces_an_unrelated_bin() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = isoforge::mesh::Mesh {
        positions: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        triangles: vec![[0, 1, 2]],
        ..Default::default()
    };
    let (gltf, bin) = (dir.path().join("scan.gltf"), dir.path().join("scan.bin"));
    std::fs::write(&bin, b"someone else's data").unwrap();
    let e = isoforge_io::write_mesh(&gltf, &mesh, MeshFormat::Gltf).unwrap_err().to_string();
    assert!(e.contains("scan.bin, which exists and is not the buffer of"), "{e}");
    assert_eq!(std::fs::read(&bin).unwrap(), b"someone else's data");
    assert!(!gltf.exists());
    std::fs::remove_file(&bin).unwrap();
    isoforge_io::write_mesh(&gltf, &mesh, MeshFormat::Gltf).unwrap();
    let first = std::fs::read(&bin).unwrap();
    // A second write replaces its own buffer.
    let bigger = isoforge::mesh::Mesh { positions: vec![[2.0; 3]; 3], ..mesh.clone() };
    isoforge_io::write_mesh(&gltf, &bigger, MeshFormat::Gltf).unwrap();
    assert_ne!(std::fs::read(&bin).unwrap(), first);
    assert_eq!(MeshFormat::Gltf.files(&gltf), [gltf.clone(), bin.clone()]);
    assert_eq!(MeshFormat::Glb.files(&gltf), [gltf]);
}

/// Writes `bytes` as `dir/name` and returns the one-line error of reading it with `limits`,
/// which must start with the path.
fn refused(dir: &Path, name: &str, bytes: &[u8], limits: Limits) -> String {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    let e = err(&p, limits);
    assert!(e.starts_with(&p.display().to_string()), "{name}: {e}");
    e
}

fn vtk_ascii(point_data: &str, values: &str) -> String {
    format!(
        "# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 2\nSPACING 1 1 1\nORIGIN 0 0 0\nPOINT_DATA {point_data}\nSCALARS v unsigned_char 1\nLOOKUP_TABLE default\n{values}\n"
    )
}

/// Issue 50 (readers): `POINT_DATA -5` was ignored and ASCII values past the declared count were
/// dropped; both are refused like a count that does not match. A keyword after the values (the
/// next array) still ends them.
#[test]
fn issue_50_vtk_negative_point_data_and_extra_ascii_values_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let values = "0 1 2 3 4 5 6 7";
    for (name, count, needle) in [
        ("neg.vtk", "-5", "POINT_DATA -5 does not match DIMENSIONS [2, 2, 2] (8 points)"),
        ("big.vtk", "9", "POINT_DATA 9 does not match DIMENSIONS [2, 2, 2] (8 points)"),
        ("words.vtk", "eight", "POINT_DATA eight does not match"),
    ] {
        let e = refused(dir.path(), name, vtk_ascii(count, values).as_bytes(), Limits::default());
        assert!(e.contains(needle), "{name}: {e}");
    }
    let e = refused(dir.path(), "extra.vtk", vtk_ascii("8", "0 1 2 3 4 5 6 7 8 9").as_bytes(), Limits::default());
    assert!(e.contains("ASCII data has more values than the 8 the header declares: value 9 is \"8\""), "{e}");
    // The same rule for NRRD's ASCII encoding.
    let text = nrrd("").replace("0 1 2 3 4 5 6 7", "0 1 2 3 4 5 6 7 1e3");
    let e = refused(dir.path(), "extra.nrrd", text.as_bytes(), Limits::default());
    assert!(e.contains("value 9 is \"1e3\""), "{e}");
    // A second array after the first is not extra values.
    let p = dir.path().join("two.vtk");
    let two = vtk_ascii("8", "0 1 2 3 4 5 6 7\nSCALARS w float 1\nLOOKUP_TABLE default\n0 0 0 0 0 0 0 0");
    std::fs::write(&p, two).unwrap();
    read_volume(&p, &Limits::default()).unwrap();
}

fn gz(data: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(data).unwrap();
    e.finish().unwrap()
}

/// Issue 50 (readers): a gzip NRRD decompressing to more bytes than declared, or holding a second
/// gzip member, was read; both are refused like trailing garbage, whole or slab by slab.
#[test]
fn issue_50_gzip_nrrd_longer_than_declared_or_with_a_second_member_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let header = b"NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: gzip\n\n".to_vec();
    let samples: Vec<u8> = (0..8).collect();
    let file = |body: Vec<u8>| [header.clone(), body].concat();
    let cases = [
        (
            "long.nrrd",
            file(gz(&[samples.clone(), vec![8]].concat())),
            "holds more than the 8 bytes the header declares",
        ),
        ("second.nrrd", file([gz(&samples), gz(&[])].concat()), "a second gzip member or trailing data"),
        ("split.nrrd", file([gz(&samples[..4]), gz(&samples[4..])].concat()), "a second gzip member"),
        ("garbage.nrrd", file([gz(&samples), b"junk".to_vec()].concat()), "trailing data"),
    ];
    for (name, bytes, needle) in &cases {
        let e = refused(dir.path(), name, bytes, Limits::default());
        assert!(e.contains("gzip data") && e.contains(needle), "{name}: {e}");
        // Slab by slab: the last slab finds it.
        let mut r = isoforge_io::read::nrrd::open_nrrd(&dir.path().join(name), &Limits::default()).unwrap();
        let mut slab = [0u8; 4];
        r.read_slab(&mut slab).unwrap();
        let e = r.read_slab(&mut slab).unwrap_err().to_string();
        assert!(e.contains(needle), "{name}, slab by slab: {e}");
    }
    let p = dir.path().join("ok.nrrd");
    std::fs::write(&p, file(gz(&samples))).unwrap();
    read_volume(&p, &Limits::default()).unwrap();
}

/// Issue 50 (readers): `vox_offset 352.5` was truncated to 352.
#[test]
fn issue_50_nifti_fractional_vox_offset_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = nifti_header([2, 2, 2], [1.0; 4], 0, 0, None, b"n+1\0");
    h[108..112].copy_from_slice(&352.5f32.to_le_bytes());
    h.push(0);
    let e = refused(dir.path(), "half.nii", &h, Limits::default());
    assert!(e.contains("vox_offset 352.5: must be a non-negative whole byte offset"), "{e}");
}

/// Issue 50 (readers): a MetaImage header line longer than the header room said "no
/// ElementDataFile".
#[test]
fn issue_50_metaimage_overlong_header_line_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "NDims = 3\nComment = {}\nDimSize = 2 2 2\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n\0\x01\x02\x03\x04\x05\x06\x07",
        "x".repeat(70_000)
    );
    let e = refused(dir.path(), "long.mha", text.as_bytes(), Limits::default());
    assert!(e.contains("line 2 is too long") && !e.contains("ElementDataFile ("), "{e}");
}

/// Issue 50 (memory caps): `--max-bytes 32M` on a large `.vti` reported "over the limit of
/// 68157440 bytes" (twice the limit and 1 MiB: the room the whole file may take). The samples
/// a header declares are refused first, with the limit asked for, before the file is read whole;
/// a file too large for its samples names the limit asked for too.
#[test]
fn issue_50_vti_over_the_limit_names_the_limit_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let limits = Limits::new(1 << 20);
    // 512 x 512 x 450 samples declared, 4 MiB of appended data: more than 3 MiB + 1 MiB of file.
    let mut big = vti("").replace("0 1 0 1 0 1", "0 511 0 511 0 449").into_bytes();
    big.resize(4 << 20, b' ');
    let e = refused(dir.path(), "big.vti", &big, limits);
    assert!(e.contains("dims 512x512x450 of u8 needs 117964800 bytes, over the limit of 1048576 bytes"), "{e}");
    // 64³ samples (256 KiB, within the limit) written as text over 3 MiB.
    let values = format!("255{}", " ".repeat(12)).repeat(64 * 64 * 64 / 2);
    let text =
        vti("").replace("0 1 0 1 0 1", "0 63 0 63 0 63").replace("0 1 2 3 4 5 6 7", &format!("{values}{values}"));
    let e = refused(dir.path(), "text.vti", text.as_bytes(), limits);
    assert!(e.contains("over the limit of 1048576 bytes") && e.contains("twice the limit"), "{e}");
}
