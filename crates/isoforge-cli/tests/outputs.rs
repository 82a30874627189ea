//! Issue 10: output safety end to end (items 5, 6, 9), error text said once, and the reader
//! bounds seen from the command line (items 2, 3).
#![cfg(target_os = "linux")]

use std::os::unix::process::ExitStatusExt;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn isoforge(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_isoforge")).args(args).output().expect("run isoforge")
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

/// Runs `args`, expects exit 2 and exactly one line `isoforge: error: {message}` on stderr.
fn fails_with(args: &[&str], message: &str) {
    let o = isoforge(args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err, format!("isoforge: error: {message}\n"), "{args:?}");
}

/// Runs `args`, expects exit 2 and one line containing `needle`; returns it.
fn fails_containing(args: &[&str], needle: &str) -> String {
    let o = isoforge(args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "{args:?}: not one line: {err}");
    assert!(err.contains(needle), "{args:?}: expected {needle:?} in {err}");
    err
}

/// Issue 10 "error text": the OS reason was printed twice ("No such file or directory (os error
/// 2): No such file or directory (os error 2)"), a missing input said "no such file: no such file".
#[test]
fn issue_10_errors_say_the_reason_once() {
    let dir = tempfile::tempdir().unwrap();
    fails_with(&["info", "/nonexistent.nrrd"], "/nonexistent.nrrd: No such file or directory");
    fails_with(&["check", "/nonexistent.ply"], "/nonexistent.ply: No such file or directory");
    fails_with(
        &["extract", "-i", "field:sphere", "-o", "/nonexistent/x.ply"],
        "/nonexistent/x.ply: the folder /nonexistent does not exist",
    );
    // Unwritable (even for root): sysfs refuses new files.
    let e = fails_containing(&["extract", "-i", "field:sphere", "-o", "/sys/x.ply"], "/sys/x.ply: ");
    let reason = e.trim_end().rsplit(": ").next().unwrap();
    assert_eq!(e.matches(reason).count(), 1, "{e}");
    assert!(!e.contains("os error"), "{e}");
    // A folder given as a file, as output and as input.
    let folder = dir.path().join("d.ply");
    std::fs::create_dir(&folder).unwrap();
    fails_with(
        &["extract", "-i", "field:sphere", "-o", p(&folder)],
        &format!("{}: -o is a folder; give a file name", folder.display()),
    );
    fails_with(&["check", p(&folder)], &format!("{}: is a folder, where a file is expected", folder.display()));
}

/// Issue 10 item 6: `-o` equal to an input (or a glTF whose buffer is the input) destroyed it.
#[test]
fn issue_10_outputs_never_overwrite_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n);
    let samples = [7u8; 64];
    for n in ["vol.ply", "scan.bin", "m.ply", "att.obj", "data.ply"] {
        std::fs::write(d(n), samples).unwrap();
    }
    std::os::unix::fs::symlink(d("vol.ply"), d("alias.ply")).unwrap();
    // Run in the folder, with relative names (as attribute specs are).
    let raw = |input: &'static str, rest: &[&'static str]| {
        let mut a = vec!["extract", "-i", input, "--dims", "4,4,4", "--dtype", "u8", "--iso", "3"];
        a.extend_from_slice(rest);
        a
    };
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (raw("vol.ply", &["-o", "vol.ply"]), "vol.ply: -o would overwrite the input (-i)"),
        (raw("vol.ply", &["-o", "alias.ply"]), "alias.ply: -o would overwrite the input vol.ply (-i)"),
        (raw("scan.bin", &["-o", "scan.gltf"]), "scan.bin: the buffer of -o would overwrite the input (-i)"),
        (raw("vol.ply", &["--mask", "m.ply", "-o", "m.ply"]), "m.ply: -o would overwrite the input (--mask)"),
        (
            raw("vol.ply", &["--attribute", "t=att.obj", "-o", "att.obj"]),
            "att.obj: -o would overwrite the input (--attribute t)",
        ),
        (
            raw("vol.ply", &["--color-volume", "m.ply", "-o", "m.ply"]),
            "m.ply: -o would overwrite the input (--color-volume)",
        ),
        (
            raw("vol.ply", &["-o", "o.ply", "--time-json", "vol.ply"]),
            "vol.ply: --time-json would overwrite the input (-i)",
        ),
        (raw("vol.ply", &["-o", "o.ply", "--time-json", "o.ply"]), "o.ply: --time-json names the same file as -o"),
    ];
    for (args, message) in &cases {
        let o = Command::new(env!("CARGO_BIN_EXE_isoforge")).args(args).current_dir(dir.path()).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err, format!("isoforge: error: {message}\n"), "{args:?}");
    }
    // A detached NRRD whose data file is the output.
    std::fs::write(
        d("h.nhdr"),
        "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nencoding: raw\ndata file: data.ply\n\n",
    )
    .unwrap();
    fails_with(
        &["extract", "-i", p(&d("h.nhdr")), "--iso", "3", "-o", p(&d("data.ply"))],
        &format!("{}: -o would overwrite the input (-i)", d("data.ply").display()),
    );
    // render of a PNG image to itself; convert of a volume to itself.
    let img = d("img.png");
    {
        let f = std::fs::File::create(&img).unwrap();
        let mut enc = png::Encoder::new(f, 8, 8);
        enc.set_color(png::ColorType::Grayscale);
        let mut w = enc.write_header().unwrap();
        w.write_image_data(&(0..64).map(|i| (i * 4) as u8).collect::<Vec<_>>()).unwrap();
    }
    let before = std::fs::read(&img).unwrap();
    fails_with(
        &["render", p(&img), "--iso", "100", "-o", p(&img)],
        &format!("{}: -o would overwrite the input", img.display()),
    );
    assert_eq!(std::fs::read(&img).unwrap(), before);
    let nrrd = d("v.nrrd");
    std::fs::write(&nrrd, "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: ascii\n\n0 1 2 3 4 5 6 7\n")
        .unwrap();
    fails_with(&["convert", p(&nrrd), p(&nrrd)], &format!("{}: the output would overwrite the input", nrrd.display()));
    // Nothing was touched, nothing was left.
    for n in ["vol.ply", "scan.bin", "m.ply", "att.obj", "data.ply"] {
        assert_eq!(std::fs::read(d(n)).unwrap(), samples, "{n}");
    }
    assert_eq!(
        names(dir.path()),
        ["alias.ply", "att.obj", "data.ply", "h.nhdr", "img.png", "m.ply", "scan.bin", "v.nrrd", "vol.ply"]
    );
}

/// Issue 10 item 6: writing out.gltf replaced an unrelated out.bin; in memory and streamed.
#[test]
fn issue_10_gltf_buffers_replace_only_their_own() {
    let dir = tempfile::tempdir().unwrap();
    let raw = dir.path().join("sphere.raw");
    sphere_raw(&raw, 24);
    let streamed = ["-i", p(&raw), "--dims", "24,24,24", "--dtype", "f32", "--iso", "0"];
    for (name, input) in [("memory", &["-i", "field:sphere"][..]), ("streamed", &streamed[..])] {
        let out = dir.path().join(name);
        std::fs::create_dir_all(&out).unwrap();
        let (gltf, bin) = (out.join("out.gltf"), out.join("out.bin"));
        std::fs::write(&bin, b"unrelated").unwrap();
        fails_with(
            &[&["extract"], input, &["-o", p(&gltf)]].concat(),
            &format!(
                "{}: -o writes its buffer to {}, which exists and is not the buffer of {}; remove it or choose another name",
                gltf.display(),
                bin.display(),
                gltf.display()
            ),
        );
        assert_eq!(std::fs::read(&bin).unwrap(), b"unrelated");
        std::fs::remove_file(&bin).unwrap();
        for _ in 0..2 {
            // The second run replaces its own pair.
            let o = isoforge(&[&["extract"], input, &["-o", p(&gltf)]].concat());
            assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
            assert_eq!(name == "streamed", String::from_utf8_lossy(&o.stderr).contains("streamed slab by slab"));
        }
        assert_eq!(names(&out), ["out.bin", "out.gltf"]);
    }
}

/// Issue 10 item 9: `--iso 70,80` left o-70.ply when the second failed; an unwritable
/// `--time-json` failed after the mesh was written.
#[test]
fn issue_10_outputs_appear_all_or_not_at_all() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("o.ply");
    // The second iso gives no surface (every point outside), after the first was meshed.
    fails_containing(&["extract", "-i", "field:sphere", "--iso", "0,-1000", "-o", p(&o)], "iso -1000 gives no surface");
    fails_containing(
        &[
            "extract",
            "-i",
            "field:sphere",
            "--iso",
            "0,-1000",
            "-o",
            p(&o),
            "--time-json",
            p(&dir.path().join("t.json")),
        ],
        "iso -1000 gives no surface",
    );
    fails_with(
        &["extract", "-i", "field:sphere", "-o", p(&o), "--time-json", "/nonexistent/t.json"],
        "/nonexistent/t.json: the folder /nonexistent does not exist",
    );
    fails_containing(&["extract", "-i", "field:sphere", "-o", p(&o), "--time-json", "/sys/t.json"], "/sys/t.json: ");
    assert!(names(dir.path()).is_empty(), "{:?}", names(dir.path()));
    // Both isos fine: both files and both timings.
    let t = dir.path().join("t.json");
    let out = isoforge(&["extract", "-i", "field:sphere", "--iso", "0,0.1", "-o", p(&o), "--time-json", p(&t)]);
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(names(dir.path()), ["o-0.1.ply", "o-0.ply", "t-0.1.json", "t-0.json"]);
}

/// A small raw f32 volume (a sphere's distance) for the streaming path.
fn sphere_raw(path: &Path, n: u32) {
    let mut bytes = Vec::with_capacity((n * n * n * 4) as usize);
    let c = (n as f32 - 1.0) / 2.0;
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let d = [i, j, k].map(|x| x as f32 - c);
                bytes.extend_from_slice(&((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() - c * 0.7).to_le_bytes());
            }
        }
    }
    std::fs::write(path, bytes).unwrap();
}

/// Issue 10 item 5: temporary names were predictable (`.NAME.tmp-PID`) and opened with
/// `File::create`, so a link planted there redirected the write.
#[test]
fn issue_10_links_planted_at_temporary_names_are_never_followed() {
    let dir = tempfile::tempdir().unwrap();
    let victim = dir.path().join("victim");
    std::fs::write(&victim, b"precious").unwrap();
    let vol = dir.path().join("vol.raw");
    sphere_raw(&vol, 24);
    // Links at the old names for the process ids the children will most likely get.
    let me = std::process::id();
    for pid in me..me + 3000 {
        for name in ["o.ply", "s.ply"] {
            for pattern in [format!(".{name}.tmp-{pid}"), format!(".{name}.faces.tmp-{pid}")] {
                std::os::unix::fs::symlink(&victim, dir.path().join(pattern)).unwrap();
            }
        }
    }
    let planted = names(dir.path()).len();
    let o = dir.path().join("o.ply");
    let s = dir.path().join("s.ply");
    let raw = ["--dims", "24,24,24", "--dtype", "f32", "--iso", "0"];
    for temp in ["anonymous", "named"] {
        for (out, stream) in [(&o, false), (&s, true)] {
            let mut args = vec!["extract", "-i", p(&vol)];
            args.extend(raw);
            args.extend(["-o", p(out)]);
            if stream {
                args.extend(["--max-memory", "8M"]);
            }
            let r =
                Command::new(env!("CARGO_BIN_EXE_isoforge")).args(&args).env("ISOFORGE_TEMP", temp).output().unwrap();
            assert_eq!(r.status.code(), Some(0), "{temp} {args:?}: {}", String::from_utf8_lossy(&r.stderr));
            assert!(std::fs::symlink_metadata(out).unwrap().file_type().is_file());
        }
    }
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    assert_eq!(names(dir.path()).len(), planted + 2, "stray files");
}

/// Waits until `ready()` or the child ends; returns false when it ended first.
fn wait_for(child: &mut std::process::Child, ready: impl Fn() -> bool) -> bool {
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(120) {
        if ready() {
            return true;
        }
        if child.try_wait().unwrap().is_some() {
            return false;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    panic!("the child neither started writing nor ended in 120 s");
}

/// Whether process `pid` is writing an anonymous (O_TMPFILE) file in `dir`: one is open there
/// and holds bytes already.
fn writes_anonymous_file(pid: u32, dir: &Path) -> bool {
    let Ok(fds) = std::fs::read_dir(format!("/proc/{pid}/fd")) else { return false };
    fds.filter_map(|e| e.ok()).any(|e| {
        let target = std::fs::read_link(e.path()).map(|t| t.to_string_lossy().into_owned()).unwrap_or_default();
        target.starts_with(&*dir.to_string_lossy())
            && target.ends_with("(deleted)")
            && std::fs::metadata(e.path()).is_ok_and(|m| m.len() > 0)
    })
}

/// Whether a named temporary file (hidden) in `dir` holds bytes already.
fn writes_named_file(dir: &Path) -> bool {
    std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .any(|e| e.file_name().to_string_lossy().starts_with('.') && e.metadata().is_ok_and(|m| m.len() > 0))
}

/// Issue 10 item 5: 6/6 signals and 23/30 kills left hidden temporary files (up to 256 MB).
/// Each signal arrives while the output is being written; the folder must end up empty.
#[test]
fn issue_10_signals_and_kills_leave_no_temporary_files() {
    let vol_dir = tempfile::tempdir().unwrap();
    let vol = vol_dir.path().join("vol.raw");
    sphere_raw(&vol, 96);
    let cases = [
        (libc::SIGINT, "named", false),
        (libc::SIGTERM, "named", false),
        (libc::SIGHUP, "named", false),
        (libc::SIGQUIT, "named", false),
        (libc::SIGTERM, "named", true),
        (libc::SIGKILL, "anonymous", false),
        (libc::SIGKILL, "anonymous", true),
    ];
    for (sig, temp, stream) in cases {
        let mut caught = false;
        for attempt in 0..5 {
            let dir = tempfile::tempdir().unwrap();
            let out = dir.path().join("big.ply");
            // A field extracted in memory and written as ASCII (slow), or a volume streamed.
            let mut args: Vec<String> = if stream {
                ["extract", "-i", p(&vol), "--dims", "96,96,96", "--dtype", "f32", "--iso", "0", "--max-memory", "8M"]
                    .map(String::from)
                    .to_vec()
            } else {
                let n = 160 + 40 * attempt;
                vec!["extract".into(), "-i".into(), format!("field:gyroid?n={n}&periods=6"), "--ascii".into()]
            };
            args.extend(["-o".to_string(), p(&out).to_string()]);
            let mut cmd = Command::new(env!("CARGO_BIN_EXE_isoforge"));
            cmd.args(&args).env("ISOFORGE_TEMP", temp).stdout(Stdio::null()).stderr(Stdio::null());
            // As in a terminal: a test run in the background (`cargo test &`) inherits SIGINT and
            // SIGQUIT ignored, which the program rightly leaves alone.
            // SAFETY: signal() is async-signal-safe; nothing else runs between fork and exec.
            unsafe {
                std::os::unix::process::CommandExt::pre_exec(&mut cmd, || {
                    for s in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP, libc::SIGQUIT] {
                        libc::signal(s, libc::SIG_DFL);
                    }
                    Ok(())
                });
            }
            let mut child = cmd.spawn().unwrap();
            let pid = child.id();
            // Mid-write: the temporary file exists and has bytes.
            let writing = wait_for(&mut child, || {
                if temp == "named" {
                    writes_named_file(dir.path())
                } else {
                    writes_anonymous_file(pid, dir.path())
                }
            });
            if !writing {
                continue; // finished before we saw it write: try a bigger output
            }
            // SAFETY: signalling our own child.
            unsafe { libc::kill(pid as i32, sig) };
            let status = child.wait().unwrap();
            if status.success() {
                continue; // the signal came after the commit
            }
            assert_eq!(status.signal(), Some(sig), "{sig} {temp}: {status:?}");
            assert!(names(dir.path()).is_empty(), "signal {sig}, {temp} temporary files: left {:?}", names(dir.path()));
            caught = true;
            break;
        }
        assert!(caught, "signal {sig} ({temp}, stream {stream}) never arrived while writing");
    }
}

/// Issue 10 item 2 from the command line: a detached NRRD on /dev/zero and a PLY linked to it
/// fail at once, in one line.
#[test]
fn issue_10_device_inputs_fail_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let nhdr = dir.path().join("z.nhdr");
    std::fs::write(
        &nhdr,
        "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 99 99 99\nencoding: ascii\ndata file: /dev/zero\n\n",
    )
    .unwrap();
    let ply = dir.path().join("z.ply");
    std::os::unix::fs::symlink("/dev/zero", &ply).unwrap();
    let start = Instant::now();
    fails_with(&["info", p(&nhdr)], "/dev/zero: is a character device, not a regular file (isoforge reads volumes and meshes from regular files only)");
    fails_with(
        &["check", p(&ply)],
        &format!(
            "{}: is a character device, not a regular file (isoforge reads volumes and meshes from regular files only)",
            ply.display()
        ),
    );
    assert!(start.elapsed() < Duration::from_secs(20));
}

/// Set in a copy of this test binary that only measures one isoforge run.
const PROBE: &str = "ISOFORGE_TEST_PROBE";

/// In the probe copy: runs isoforge with the arguments in `PROBE`, waits for it with wait4 and
/// prints its exit code, stderr and peak resident memory. Returns false outside a probe.
// Reaped by wait4 (std's wait would not give the child's rusage).
#[allow(clippy::zombie_processes)]
fn probe() -> bool {
    let Ok(args) = std::env::var(PROBE) else { return false };
    let child = Command::new(env!("CARGO_BIN_EXE_isoforge"))
        .args(args.split('\u{1f}'))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id() as i32;
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.unwrap(), &mut err).unwrap();
    let mut status = 0;
    // SAFETY: zeroed rusage is valid; waiting for our own child, which std has not reaped.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    assert_eq!(unsafe { libc::wait4(pid, &mut status, 0, &mut usage) }, pid);
    let code = libc::WIFEXITED(status).then(|| libc::WEXITSTATUS(status));
    let v = serde_json::json!({ "code": code, "stderr": err, "peak": usage.ru_maxrss as u64 * 1024 });
    println!("PROBE {v}");
    true
}

/// Exit code, stderr and peak resident memory (bytes) of `isoforge args`, measured from a fresh,
/// small process (this binary run again for test `test`): what the kernel counts as a child's
/// peak includes its parent's memory at the time of the spawn, which here is the whole harness.
fn run_measured(test: &str, args: &[&str]) -> (Option<i32>, String, u64) {
    let out = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", test, "--nocapture", "--test-threads=1"])
        .env(PROBE, args.join("\u{1f}"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let json = text.lines().find_map(|l| l.split_once("PROBE ").map(|(_, r)| r)).unwrap_or_else(|| panic!("{text}"));
    let v: serde_json::Value = serde_json::from_str(json).unwrap();
    (v["code"].as_i64().map(|c| c as i32), v["stderr"].as_str().unwrap().to_string(), v["peak"].as_u64().unwrap())
}

/// An 8-bit greyscale PNG of `w` x `h` zeros (compresses to almost nothing).
fn zeros_png(path: &Path, w: u32, h: u32) {
    let f = std::fs::File::create(path).unwrap();
    let mut enc = png::Encoder::new(std::io::BufWriter::new(f), w, h);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_compression(png::Compression::Fast);
    let mut writer = enc.write_header().unwrap();
    writer.write_image_data(&vec![0u8; (w * h) as usize]).unwrap();
}

/// Issue 10 item 3: an 854 KB PNG of 30000 x 30000 drove `contour` to 7.7 GB: the image was
/// read, then its slice copied as f64 (8 bytes a pixel) whatever --max-bytes said.
#[test]
fn issue_10_contour_memory_stays_within_max_bytes() {
    if probe() {
        return;
    }
    let test = "issue_10_contour_memory_stays_within_max_bytes";
    let dir = tempfile::tempdir().unwrap();
    let img = dir.path().join("big.png");
    zeros_png(&img, 6000, 6000);
    let svg = dir.path().join("c.svg");
    // 36 MB of samples fit 64M; their f64 copy (288 MB) does not: refused before it is made.
    let (code, err, peak) =
        run_measured(test, &["contour", p(&img), "--iso", "0.5", "-o", p(&svg), "--max-bytes", "64M"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("needs 288000000 bytes as f64, over the limit of 67108864 bytes"), "{err}");
    assert!(peak < 150 << 20, "peak {} MiB", peak >> 20);
    // Below the image's own size: refused before decoding.
    let (code, err, peak) =
        run_measured(test, &["contour", p(&img), "--iso", "0.5", "-o", p(&svg), "--max-bytes", "1M"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("6000 x 6000 image needs 36000000 bytes, over the limit"), "{err}");
    assert!(peak < 40 << 20, "peak {} MiB", peak >> 20);
    assert_eq!(names(dir.path()), ["big.png"]);
    // Within the limit, it works.
    let small = dir.path().join("small.png");
    {
        let mut enc = png::Encoder::new(std::fs::File::create(&small).unwrap(), 64, 64);
        enc.set_color(png::ColorType::Grayscale);
        let ramp: Vec<u8> = (0..64 * 64).map(|i| (i % 64) as u8).collect();
        enc.write_header().unwrap().write_image_data(&ramp).unwrap();
    }
    let (code, err, _) = run_measured(test, &["contour", p(&small), "--iso", "0.5", "-o", p(&svg)]);
    assert_eq!(code, Some(0), "{err}");
}
