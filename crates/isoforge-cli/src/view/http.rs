//! The viewer's HTTP/1.1 server: `GET` and `HEAD`, one request per connection
//! (`Connection: close`), hardened for a loopback port any local page or process can reach.
//!
//! - One thread accepts and reads requests on non-blocking sockets (`poll`; where there is none,
//!   a 5 ms sleep and a try of each), holding up to [`Limits::pending`] incomplete ones and
//!   dropping the oldest when full. It owns the whole request: the head is checked there (caps,
//!   method, `Host`) and the body read there (capped, dropped), so only complete, checked
//!   requests reach the workers, in two lanes (work: mesh/check/export; fast: the rest) so the
//!   page and `/api/info` are not queued behind exports. A full lane queue is answered 503 at once.
//! - Malformed input (a first byte that is not a method letter, as a TLS ClientHello; LF-only line
//!   endings) is refused as soon as it arrives; so is every other refusal of the head.
//! - The request line, the header block and the body are capped ([`Limits`]) and must arrive
//!   within one deadline, so a client that trickles bytes (slowloris) holds one pending slot for
//!   a bounded time and no worker; a response must be read at [`Limits::min_read_rate`], so a
//!   client that never reads frees its worker too.
//! - `HEAD` of a work endpoint is 405 (`Allow: GET`): its headers would need the work done.
//! - `Host` must name this server (`127.0.0.1:PORT`, `localhost:PORT` or `[::1]:PORT`): a page
//!   whose DNS name was rebound to 127.0.0.1 still sends its own name and gets 403.
//! - A handler can ask [`Request::is_abandoned`] between steps of long work: true once the client
//!   closed its end (a page aborts a stale request), so the work can stop.

use std::io::{ErrorKind, Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, TrySendError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Caps and timeouts of the server.
#[derive(Debug, Clone)]
pub struct Limits {
    /// Worker threads of the work lane (meshes, checks, exports served at once).
    pub workers: usize,
    /// Worker threads of the fast lane (the page, `/api/info`, `/api/status`, refusals).
    pub fast_workers: usize,
    /// Complete requests waiting for a worker, per lane; beyond this, 503.
    pub queue: usize,
    /// Connections whose request is still arriving; a new one beyond this drops the oldest.
    pub pending: usize,
    /// Longest request line (`GET /path?query HTTP/1.1`), bytes; longer is 414.
    pub request_line: usize,
    /// Largest header block after the request line, bytes; larger is 431.
    pub headers: usize,
    /// Largest request body (the API reads none), bytes; larger is 413.
    pub body: usize,
    /// The whole request (line, headers, body) must arrive within this; later is 408.
    pub request_deadline: Duration,
    /// Longest wait for one read or write to make progress.
    pub io_timeout: Duration,
    /// A response of `n` bytes must be read within `io_timeout + n / min_read_rate` seconds.
    pub min_read_rate: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            workers: 8,
            fast_workers: 2,
            queue: 32,
            pending: 4096,
            request_line: 8 * 1024,
            headers: 16 * 1024,
            body: 64 * 1024,
            request_deadline: Duration::from_secs(5),
            io_timeout: Duration::from_secs(10),
            min_read_rate: 1 << 20,
        }
    }
}

/// Counters of what the server did, for `/api/status` and the tests.
#[derive(Debug, Default)]
pub struct Stats {
    /// Responses written in full.
    pub served: AtomicU64,
    /// Requests whose client went away before the response was written (work skipped or cut).
    pub abandoned: AtomicU64,
    /// Requests refused for a limit, a timeout, a bad `Host` or a full queue.
    pub refused: AtomicU64,
}

/// A parsed request, and its connection for [`Request::is_abandoned`].
pub struct Request<'a> {
    /// The path, still percent-encoded.
    pub path: String,
    /// The query string after `?`, still percent-encoded (empty when absent).
    pub query: String,
    stream: &'a TcpStream,
}

impl Request<'_> {
    /// True once the client has closed its end of the connection or reset it: nobody will read
    /// the response. Costs one non-blocking `peek`.
    pub fn is_abandoned(&self) -> bool {
        if self.stream.set_nonblocking(true).is_err() {
            return true;
        }
        let r = self.stream.peek(&mut [0u8; 1]);
        let _ = self.stream.set_nonblocking(false);
        match r {
            Ok(0) => true,
            Ok(_) => false,
            Err(e) => e.kind() != ErrorKind::WouldBlock,
        }
    }
}

/// What a handler answers.
pub struct Response {
    /// HTTP status code.
    pub status: u16,
    /// `Content-Type`.
    pub content_type: &'static str,
    /// Extra headers (`Content-Disposition`, …).
    pub headers: Vec<(&'static str, String)>,
    /// The body.
    pub body: Body,
}

/// A response body: computed, or embedded in the binary.
pub enum Body {
    /// Made for this request.
    Owned(Vec<u8>),
    /// A static file of the page.
    Static(&'static [u8]),
    /// Written straight to the connection as it is made (an export), without `Content-Length`: the
    /// close ends it. Held memory is what the writer holds, not the whole body.
    Stream(Writer),
}

/// Writes a streamed body; an error stops it (the client went away or stopped reading).
pub type Writer = Box<dyn FnOnce(&mut dyn Write) -> std::io::Result<()> + Send>;

/// A body writer that holds the client to [`Limits::min_read_rate`] from its start.
struct Paced<'a> {
    stream: &'a mut TcpStream,
    start: Instant,
    written: u64,
    limits: &'a Limits,
}

impl Write for Paced<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let allowed =
            Duration::from_secs_f64((self.written + buf.len() as u64) as f64 / self.limits.min_read_rate.max(1) as f64);
        write_all_by(self.stream, buf, self.start + self.limits.io_timeout + allowed, self.limits)?;
        self.written += buf.len() as u64;
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Response {
    /// A body of the given type with status 200.
    pub fn ok(content_type: &'static str, body: Body) -> Response {
        Response { status: 200, content_type, headers: Vec::new(), body }
    }

    /// A plain-text error.
    pub fn error(status: u16, message: impl Into<String>) -> Response {
        let mut m = message.into();
        m.push('\n');
        Response { status, content_type: "text/plain; charset=utf-8", headers: Vec::new(), body: Body::Owned(m.into()) }
    }

    /// Marks the response as abandoned: the client went away, nothing is written.
    pub fn abandoned() -> Response {
        Response::error(STATUS_ABANDONED, "")
    }
}

/// Not sent: tells [`serve`] that the handler stopped because the client went away.
const STATUS_ABANDONED: u16 = 499;

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        413 => "Content Too Large",
        414 => "URI Too Long",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        501 => "Not Implemented",
        503 => "Service Unavailable",
        505 => "HTTP Version Not Supported",
        _ => "Error",
    }
}

/// A handler: one request in, one response out; may run on several workers at once.
pub type Handler = dyn Fn(&Request) -> Response + Send + Sync;

/// Serves `listener` until the process ends: this thread accepts and reads requests, the workers
/// answer them.
///
/// Reading is one `poll` loop over non-blocking sockets holding up to [`Limits::pending`]
/// incomplete requests (the oldest is dropped when a new one needs room), so silent or trickling
/// clients hold no worker. This thread owns the whole request: it checks the head (limits, method,
/// `Host`) and reads the body (capped at [`Limits::body`], dropped: the API takes none) before a
/// worker sees it. A complete request goes to one of two lanes: `/api/mesh`, `/api/check` and
/// `/api/export` to the work lane ([`Limits::workers`]), everything else (the page, `/api/info`,
/// `/api/status`) to the fast lane ([`Limits::fast_workers`]).
pub fn serve(listener: TcpListener, limits: Limits, stats: Arc<Stats>, handler: Arc<Handler>) {
    let port = listener.local_addr().map(|a| a.port()).unwrap_or(0);
    let hosts = [format!("127.0.0.1:{port}"), format!("localhost:{port}"), format!("[::1]:{port}")];
    let lane = |workers: usize| {
        let (tx, rx) = sync_channel::<Head>(limits.queue);
        let rx = Arc::new(Mutex::new(rx));
        for _ in 0..workers.max(1) {
            let (rx, limits, stats, handler) = (rx.clone(), limits.clone(), stats.clone(), handler.clone());
            std::thread::spawn(move || worker(&rx, &limits, &stats, &*handler));
        }
        tx
    };
    let (work, fast) = (lane(limits.workers), lane(limits.fast_workers));
    if listener.set_nonblocking(true).is_err() {
        return;
    }
    let mut pending: Vec<Head> = Vec::new();
    loop {
        let Ok(readable) = wait_readable(&listener, &pending) else { return };
        let now = Instant::now();
        let mut kept = Vec::with_capacity(pending.len());
        for (mut h, ready) in pending.drain(..).zip(readable) {
            let step = if ready { read_more(&mut h, &limits, &hosts) } else { Step::Wait };
            let step = match step {
                Step::Wait if now >= h.deadline => Step::Refuse(Refusal::new(
                    408,
                    format!("request not received within {:?}", limits.request_deadline),
                )),
                s => s,
            };
            match step {
                Step::Wait => kept.push(h),
                Step::Drop => {}
                Step::Refuse(r) => {
                    stats.refused.fetch_add(1, Ordering::Relaxed);
                    refuse_now(h.stream, r);
                }
                Step::Ready => {
                    let tx = if h.parsed.as_ref().is_some_and(|p| is_work(&p.path)) { &work } else { &fast };
                    let _ = h.stream.set_nonblocking(false);
                    match tx.try_send(h) {
                        Ok(()) => {}
                        Err(TrySendError::Full(h)) => {
                            stats.refused.fetch_add(1, Ordering::Relaxed);
                            let mut r = Refusal::new(503, "busy: too many requests, retry later".into());
                            r.headers.push(("Retry-After", "1".into()));
                            refuse_now(h.stream, r);
                        }
                        Err(TrySendError::Disconnected(_)) => return,
                    }
                }
            }
        }
        pending = kept;
        loop {
            match listener.accept() {
                Ok((stream, _)) => {
                    if stream.set_nonblocking(true).is_err() {
                        continue;
                    }
                    if pending.len() >= limits.pending.max(1) {
                        // The oldest incomplete request makes room: a newcomer is never refused for
                        // clients that do not finish theirs.
                        pending.remove(0);
                        stats.refused.fetch_add(1, Ordering::Relaxed);
                    }
                    pending.push(Head {
                        stream,
                        buf: Vec::new(),
                        deadline: Instant::now() + limits.request_deadline,
                        parsed: None,
                        body_left: 0,
                    });
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                Err(_) => {
                    // Out of descriptors: the oldest incomplete request gives its back.
                    if !pending.is_empty() {
                        pending.remove(0);
                        stats.refused.fetch_add(1, Ordering::Relaxed);
                    }
                    break;
                }
            }
        }
    }
}

/// Waits (at most 100 ms) until the listener or a pending connection has input; says which
/// pending connections have.
#[cfg(unix)]
fn wait_readable(listener: &TcpListener, pending: &[Head]) -> std::io::Result<Vec<bool>> {
    use std::os::fd::AsRawFd;
    let mut fds = Vec::with_capacity(pending.len() + 1);
    fds.push(libc::pollfd { fd: listener.as_raw_fd(), events: libc::POLLIN, revents: 0 });
    fds.extend(pending.iter().map(|h| libc::pollfd { fd: h.stream.as_raw_fd(), events: libc::POLLIN, revents: 0 }));
    // SAFETY: `fds` is a valid array of `fds.len()` pollfd for the duration of the call.
    let n = unsafe { libc::poll(fds.as_mut_ptr(), fds.len() as libc::nfds_t, 100) };
    if n < 0 {
        let e = std::io::Error::last_os_error();
        if e.kind() != ErrorKind::Interrupted {
            return Err(e);
        }
    }
    Ok(fds[1..].iter().map(|f| f.revents != 0).collect())
}

/// Without `poll`: a short sleep, then every pending connection is tried (a non-blocking read of
/// a connection with nothing to read returns at once).
#[cfg(not(unix))]
fn wait_readable(_listener: &TcpListener, pending: &[Head]) -> std::io::Result<Vec<bool>> {
    std::thread::sleep(Duration::from_millis(5));
    Ok(vec![true; pending.len()])
}

/// A connection, the bytes of its request head read so far, and once the head is checked, the
/// request and the body bytes still to come.
struct Head {
    stream: TcpStream,
    buf: Vec<u8>,
    deadline: Instant,
    parsed: Option<Parsed>,
    body_left: usize,
}

/// A checked request head.
struct Parsed {
    method: &'static str,
    path: String,
    query: String,
}

enum Step {
    /// Incomplete: keep reading.
    Wait,
    /// The request (head and body) is complete and checked.
    Ready,
    /// Closed before sending anything, or reset.
    Drop,
    /// Answered at once by the reading thread.
    Refuse(Refusal),
}

/// Why a request was not handed to the handler: the status, the message, extra headers.
struct Refusal {
    status: u16,
    message: String,
    headers: Vec<(&'static str, String)>,
}

impl Refusal {
    fn new(status: u16, message: String) -> Refusal {
        Refusal { status, message, headers: Vec::new() }
    }
}

/// Reads what the non-blocking `h.stream` holds: the head (checked as soon as it is complete,
/// malformed input refused as soon as it arrives), then the body, dropped.
fn read_more(h: &mut Head, limits: &Limits, hosts: &[String; 3]) -> Step {
    let cap = limits.request_line + 2 + limits.headers + 2;
    let mut chunk = [0u8; 4096];
    loop {
        if h.parsed.is_some() {
            if h.body_left == 0 {
                return Step::Ready;
            }
            match h.stream.read(&mut chunk[..h.body_left.min(4096)]) {
                Ok(0) => return Step::Refuse(Refusal::new(400, "connection closed inside the body".into())),
                Ok(n) => h.body_left -= n,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) if e.kind() == ErrorKind::WouldBlock => return Step::Wait,
                Err(_) => return Step::Drop,
            }
            continue;
        }
        let room = (cap - h.buf.len().min(cap)).min(chunk.len());
        // (bytes read, connection closed)
        let (got, closed) = match h.stream.read(&mut chunk[..room]) {
            _ if room == 0 => (0, false),
            Ok(0) => (0, true),
            Ok(n) => {
                h.buf.extend_from_slice(&chunk[..n]);
                (n, false)
            }
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) if e.kind() == ErrorKind::WouldBlock => (0, false),
            Err(_) => return Step::Drop,
        };
        if let Some(&b) = h.buf.first() {
            if !b.is_ascii_uppercase() {
                return Step::Refuse(Refusal::new(400, "not an HTTP request (TLS is not served: use http://)".into()));
            }
        }
        let bare_lf = h.buf.iter().enumerate().any(|(i, &b)| b == b'\n' && (i == 0 || h.buf[i - 1] != b'\r'));
        if bare_lf {
            return Step::Refuse(Refusal::new(400, "lines must end with CRLF".into()));
        }
        if let Some(end) = h.buf.windows(4).position(|w| w == b"\r\n\r\n") {
            let (parsed, length) = match parse_head(&h.buf[..end], limits, hosts) {
                Ok(p) => p,
                Err(r) => return Step::Refuse(r),
            };
            h.body_left = length.saturating_sub(h.buf.len() - (end + 4));
            h.parsed = Some(parsed);
            h.buf = Vec::new();
            continue;
        }
        let line_end = h.buf.windows(2).position(|w| w == b"\r\n").unwrap_or(h.buf.len());
        if line_end > limits.request_line {
            return Step::Refuse(Refusal::new(414, format!("request line longer than {} bytes", limits.request_line)));
        }
        if h.buf.len() >= cap {
            return Step::Refuse(Refusal::new(431, format!("headers longer than {} bytes", limits.headers)));
        }
        if got > 0 && got == room {
            continue; // a full chunk: there may be more
        }
        return match (closed, h.buf.is_empty()) {
            (true, true) => Step::Drop,
            (true, false) => Step::Refuse(Refusal::new(400, "connection closed inside the request".into())),
            (false, _) => Step::Wait,
        };
    }
}

/// True when the request's path is one of the expensive endpoints.
fn is_work(path: &str) -> bool {
    matches!(path, "/api/mesh" | "/api/check" | "/api/export")
}

/// Answers a refusal from the reading thread: a short head on a fresh socket fits its buffer, so the
/// non-blocking write does not wait; then the connection is closed.
fn refuse_now(mut stream: TcpStream, refusal: Refusal) {
    let mut r = Response::error(refusal.status, refusal.message);
    r.headers = refusal.headers;
    let Body::Owned(body) = &r.body else { return };
    let mut out = Vec::new();
    let _ = write_head(&mut out, &r, Some(body.len()));
    out.extend_from_slice(body);
    let _ = stream.write(&out);
    let _ = stream.shutdown(Shutdown::Write);
}

fn worker(rx: &Mutex<Receiver<Head>>, limits: &Limits, stats: &Stats, handler: &Handler) {
    loop {
        let next = match rx.lock() {
            Ok(rx) => rx.recv(),
            Err(_) => return,
        };
        let Ok(head) = next else { return };
        let _ = head.stream.set_nodelay(true);
        connection(head, limits, stats, handler);
    }
}

fn connection(head: Head, limits: &Limits, stats: &Stats, handler: &Handler) {
    let Head { mut stream, parsed, .. } = head;
    let Some(Parsed { method, path, query }) = parsed else { return };
    let req = Request { path, query, stream: &stream };
    // A panic in a handler is a bug; it costs this request, not the server.
    let mut response = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| handler(&req)))
        .unwrap_or_else(|_| Response::error(500, "internal error: this is a bug, please report it"));
    if response.status == STATUS_ABANDONED {
        stats.abandoned.fetch_add(1, Ordering::Relaxed);
        return;
    }
    let head_only = method == "HEAD";
    if let Body::Stream(_) = response.body {
        let Body::Stream(writer) = std::mem::replace(&mut response.body, Body::Static(b"")) else { return };
        let written = write_head(&mut stream, &response, None).and_then(|()| {
            if head_only {
                return Ok(());
            }
            let paced = Paced { stream: &mut stream, start: Instant::now(), written: 0, limits };
            let mut w = std::io::BufWriter::with_capacity(256 * 1024, paced);
            writer(&mut w)?;
            w.flush()
        });
        if written.is_ok() {
            stats.served.fetch_add(1, Ordering::Relaxed);
            close_gently(stream);
        } else {
            stats.abandoned.fetch_add(1, Ordering::Relaxed);
        }
        return;
    }
    let body: &[u8] = match &response.body {
        Body::Owned(b) => b,
        Body::Static(b) => b,
        Body::Stream(_) => &[],
    };
    let budget = limits.io_timeout + Duration::from_secs_f64(body.len() as f64 / limits.min_read_rate.max(1) as f64);
    let written = write_head(&mut stream, &response, Some(body.len())).and_then(|()| {
        if head_only {
            Ok(())
        } else {
            write_all_by(&mut stream, body, Instant::now() + budget, limits)
        }
    });
    if written.is_ok() {
        if response.status < 400 {
            stats.served.fetch_add(1, Ordering::Relaxed);
        }
        close_gently(stream);
    } else {
        stats.abandoned.fetch_add(1, Ordering::Relaxed);
    }
}

/// Checks a complete request head (without its blank line): the request line, the headers,
/// `Host`; answers the request and the length of its body.
fn parse_head(head: &[u8], limits: &Limits, hosts: &[String; 3]) -> Result<(Parsed, usize), Refusal> {
    let bad = |m: String| Refusal::new(400, m);
    let head = std::str::from_utf8(head).map_err(|_| bad("request head is not UTF-8".into()))?;
    let mut lines = head.split("\r\n");
    let line = lines.next().unwrap_or("");
    if line.len() > limits.request_line {
        return Err(Refusal::new(414, format!("request line longer than {} bytes", limits.request_line)));
    }
    if head.len() - line.len() > limits.headers + 2 {
        return Err(Refusal::new(431, format!("headers longer than {} bytes", limits.headers)));
    }
    let mut parts = line.split(' ');
    let (Some(method), Some(target), Some(version), None) = (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Err(bad("malformed request line".into()));
    };
    let method = match method {
        "GET" => "GET",
        "HEAD" => "HEAD",
        m => {
            let mut r = Refusal::new(405, format!("method {m:?}: only GET and HEAD"));
            r.headers.push(("Allow", "GET, HEAD".into()));
            return Err(r);
        }
    };
    if version != "HTTP/1.1" && version != "HTTP/1.0" {
        return Err(Refusal::new(505, format!("{version:?}: only HTTP/1.0 and HTTP/1.1")));
    }
    if !target.starts_with('/') {
        return Err(Refusal::new(400, "the request target must be a path".into()));
    }
    let (mut host, mut length): (Option<&str>, Option<usize>) = (None, None);
    for h in lines {
        let (name, value) = h.split_once(':').ok_or_else(|| bad(format!("malformed header {h:?}")))?;
        let value = value.trim();
        if name.eq_ignore_ascii_case("host") {
            if host.is_some() {
                return Err(bad("more than one Host header".into()));
            }
            host = Some(value);
        } else if name.eq_ignore_ascii_case("content-length") {
            let n = value.parse().map_err(|_| bad(format!("Content-Length {value:?}: not a number")))?;
            if length.is_some_and(|l| l != n) {
                return Err(bad("conflicting Content-Length headers".into()));
            }
            length = Some(n);
        } else if name.eq_ignore_ascii_case("transfer-encoding") {
            return Err(Refusal::new(501, "Transfer-Encoding in a request is not accepted".into()));
        }
    }
    match host {
        None => return Err(bad("Host header required".into())),
        Some(h) if !hosts.iter().any(|ok| ok.eq_ignore_ascii_case(h)) => {
            let accepted = hosts.join(", ");
            return Err(Refusal::new(403, format!("Host {h:?} is not this server (accepted: {accepted})")));
        }
        Some(_) => {}
    }
    let length = length.unwrap_or(0);
    if length > limits.body {
        return Err(Refusal::new(413, format!("body of {length} bytes: at most {}", limits.body)));
    }
    let (path, query) = target.split_once('?').unwrap_or((target, ""));
    if method == "HEAD" && is_work(path) {
        // Its headers would need the work done (or started): refused before any is.
        let mut r = Refusal::new(405, format!("HEAD {path}: only GET (its answer is made by extracting)"));
        r.headers.push(("Allow", "GET".into()));
        return Err(r);
    }
    Ok((Parsed { method, path: path.to_string(), query: query.to_string() }, length))
}

fn write_head(stream: &mut impl Write, r: &Response, len: Option<usize>) -> std::io::Result<()> {
    let len = len.map(|n| format!("Content-Length: {n}\r\n")).unwrap_or_default();
    let mut head = format!(
        "HTTP/1.1 {} {}\r\nContent-Type: {}\r\n{len}Connection: close\r\n\
         Cache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nCross-Origin-Resource-Policy: same-origin\r\n",
        r.status,
        reason(r.status),
        r.content_type
    );
    for (k, v) in &r.headers {
        head.push_str(&format!("{k}: {v}\r\n"));
    }
    head.push_str("\r\n");
    stream.write_all(head.as_bytes())
}

/// Writes `body`, giving up at `deadline` or when one write makes no progress for `io_timeout`.
fn write_all_by(stream: &mut TcpStream, mut body: &[u8], deadline: Instant, limits: &Limits) -> std::io::Result<()> {
    const CHUNK: usize = 256 * 1024;
    while !body.is_empty() {
        let left = deadline
            .checked_duration_since(Instant::now())
            .filter(|d| !d.is_zero())
            .ok_or_else(|| std::io::Error::from(ErrorKind::TimedOut))?;
        stream.set_write_timeout(Some(left.min(limits.io_timeout)))?;
        match stream.write(&body[..body.len().min(CHUNK)]) {
            Ok(0) => return Err(ErrorKind::WriteZero.into()),
            Ok(n) => body = &body[n..],
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// Ends the connection after a response: our side first, then whatever the client still sends is
/// read for a moment (at most [`LINGER`], 64 KiB), so unread request bytes do not turn the close
/// into a reset that loses the response.
fn close_gently(mut stream: TcpStream) {
    let _ = stream.shutdown(Shutdown::Write);
    let until = Instant::now() + LINGER;
    let mut sink = [0u8; 4096];
    let mut budget = 64 * 1024usize;
    while let Some(left) = until.checked_duration_since(Instant::now()).filter(|d| !d.is_zero()) {
        let _ = stream.set_read_timeout(Some(left));
        match stream.read(&mut sink) {
            Ok(n) if n > 0 && n < budget => budget -= n,
            _ => break,
        }
    }
}

/// How long [`close_gently`] waits for the client to close.
const LINGER: Duration = Duration::from_millis(500);

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};

    /// A server with short timeouts on a free port, answering `size` bytes of 'x' on every path.
    fn server(limits: Limits, size: usize) -> (String, Arc<Stats>) {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap().to_string();
        let stats = Arc::new(Stats::default());
        let s = stats.clone();
        let body: &'static [u8] = Box::leak(vec![b'x'; size].into_boxed_slice());
        std::thread::spawn(move || {
            serve(listener, limits, s, Arc::new(move |_: &Request| Response::ok("text/plain", Body::Static(body))))
        });
        (addr, stats)
    }

    fn quick() -> Limits {
        Limits {
            workers: 2,
            queue: 2,
            request_deadline: Duration::from_millis(400),
            io_timeout: Duration::from_millis(300),
            min_read_rate: 1 << 20,
            ..Limits::default()
        }
    }

    /// The status code of the answer to `raw`, read until the server closes.
    fn ask(addr: &str, raw: &[u8]) -> u16 {
        let mut s = TcpStream::connect(addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        let _ = s.write_all(raw);
        let mut out = Vec::new();
        let _ = s.read_to_end(&mut out);
        let head = String::from_utf8_lossy(&out[..out.len().min(64)]).into_owned();
        head.split_whitespace().nth(1).and_then(|c| c.parse().ok()).unwrap_or(0)
    }

    fn get(host: &str) -> Vec<u8> {
        format!("GET /x HTTP/1.1\r\nHost: {host}\r\n\r\n").into_bytes()
    }

    #[test]
    fn limits_and_host_are_enforced() {
        let (addr, stats) = server(quick(), 10);
        let port = addr.rsplit(':').next().unwrap();
        assert_eq!(ask(&addr, &get(&addr)), 200);
        assert_eq!(ask(&addr, &get(&format!("localhost:{port}"))), 200);
        assert_eq!(ask(&addr, &get(&format!("LOCALHOST:{port}"))), 200);
        assert_eq!(ask(&addr, &get(&format!("[::1]:{port}"))), 200);
        assert_eq!(ask(&addr, &get(&format!("evil.example:{port}"))), 403);
        assert_eq!(ask(&addr, &get("127.0.0.1:1")), 403);
        assert_eq!(ask(&addr, &get("localhost")), 403);
        assert_eq!(ask(&addr, b"GET /x HTTP/1.1\r\n\r\n"), 400);
        let long = format!("GET /{} HTTP/1.1\r\nHost: {addr}\r\n\r\n", "a".repeat(9000));
        assert_eq!(ask(&addr, long.as_bytes()), 414);
        let many = format!(
            "GET / HTTP/1.1\r\nHost: {addr}\r\n{}\r\n",
            "X-Pad: 0123456789012345678901234567890123456789\r\n".repeat(400)
        );
        assert_eq!(ask(&addr, many.as_bytes()), 431);
        let big = format!("GET / HTTP/1.1\r\nHost: {addr}\r\nContent-Length: 1000000000\r\n\r\n");
        assert_eq!(ask(&addr, big.as_bytes()), 413);
        let chunked = format!("GET / HTTP/1.1\r\nHost: {addr}\r\nTransfer-Encoding: chunked\r\n\r\n");
        assert_eq!(ask(&addr, chunked.as_bytes()), 501);
        assert_eq!(ask(&addr, format!("POST / HTTP/1.1\r\nHost: {addr}\r\n\r\n").as_bytes()), 405);
        assert_eq!(ask(&addr, format!("GET / HTTP/2\r\nHost: {addr}\r\n\r\n").as_bytes()), 505);
        assert_eq!(ask(&addr, format!("GET http://x/ HTTP/1.1\r\nHost: {addr}\r\n\r\n").as_bytes()), 400);
        let with_body = format!("GET / HTTP/1.1\r\nHost: {addr}\r\nContent-Length: 5\r\n\r\nhello");
        assert_eq!(ask(&addr, with_body.as_bytes()), 200);
        // HEAD: the length of the body, not the body.
        let mut s = TcpStream::connect(&addr).unwrap();
        write!(s, "HEAD /x HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
        let mut out = String::new();
        s.read_to_string(&mut out).unwrap();
        assert!(out.starts_with("HTTP/1.1 200 OK\r\n") && out.contains("Content-Length: 10\r\n"), "{out}");
        assert!(out.ends_with("\r\n\r\n"), "{out}");
        assert_eq!(stats.refused.load(Ordering::Relaxed), 11);
    }

    #[test]
    fn a_trickling_client_is_cut_at_the_deadline() {
        let (addr, stats) = server(quick(), 10);
        let mut s = TcpStream::connect(&addr).unwrap();
        let start = Instant::now();
        write!(s, "GET /x HTTP/1.1\r\nHost: {addr}\r\nContent-Length: 100\r\n\r\n").unwrap();
        // One byte every 50 ms: every read makes progress, the whole request never arrives.
        let mut cut = false;
        for _ in 0..100 {
            std::thread::sleep(Duration::from_millis(50));
            if s.write_all(b"x").is_err() {
                cut = true;
                break;
            }
            s.set_nonblocking(true).unwrap();
            let mut b = [0u8; 64];
            let r = s.read(&mut b);
            s.set_nonblocking(false).unwrap();
            if let Ok(n) = r {
                assert!(n == 0 || String::from_utf8_lossy(&b[..n]).starts_with("HTTP/1.1 408"), "{:?}", &b[..n]);
                cut = true;
                break;
            }
        }
        assert!(cut, "still connected after 5 s");
        let t = start.elapsed();
        assert!(t >= Duration::from_millis(350) && t < Duration::from_millis(1500), "cut after {t:?}");
        assert_eq!(stats.refused.load(Ordering::Relaxed), 1);
    }

    #[test]
    fn a_client_that_never_reads_frees_its_worker() {
        // 32 MB: more than the socket buffers hold, so the write blocks until the deadline
        // (io_timeout + 32 MB at 1 MB/s would be 32 s; io_timeout alone bounds one stuck write).
        let (addr, stats) = server(quick(), 32 << 20);
        let mut stalled = TcpStream::connect(&addr).unwrap();
        stalled.write_all(&get(&addr)).unwrap();
        let start = Instant::now();
        while stats.abandoned.load(Ordering::Relaxed) == 0 {
            assert!(start.elapsed() < Duration::from_secs(5), "the stalled response is still being written");
            std::thread::sleep(Duration::from_millis(20));
        }
        drop(stalled);
    }

    #[test]
    fn a_full_queue_is_answered_503() {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap().to_string();
        let stats = Arc::new(Stats::default());
        let (s, limits) = (stats.clone(), Limits { workers: 1, fast_workers: 1, queue: 1, ..quick() });
        // A slow handler: one request works, one waits in the queue, the rest are refused.
        std::thread::spawn(move || {
            serve(
                listener,
                limits,
                s,
                Arc::new(|_: &Request| {
                    std::thread::sleep(Duration::from_millis(300));
                    Response::ok("text/plain", Body::Static(b"ok"))
                }),
            )
        });
        let req = format!("GET /api/export HTTP/1.1\r\nHost: {addr}\r\n\r\n");
        let mut held: Vec<TcpStream> = (0..5)
            .map(|_| {
                let mut c = TcpStream::connect(&addr).unwrap();
                c.write_all(req.as_bytes()).unwrap();
                c
            })
            .collect();
        let (mut codes, mut answers) = (Vec::new(), Vec::new());
        for c in &mut held {
            c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
            let mut out = String::new();
            let _ = c.read_to_string(&mut out);
            codes.push(out.split_whitespace().nth(1).unwrap_or("").to_string());
            answers.push(out);
        }
        let refused = codes.iter().filter(|c| *c == "503").count();
        assert!(codes.iter().any(|c| c == "200") && refused >= 1, "{codes:?}");
        assert!(answers.iter().filter(|a| a.contains("Retry-After: 1\r\n")).count() == refused);
        assert_eq!(stats.refused.load(Ordering::Relaxed) as usize, refused);
    }

    #[test]
    fn silent_clients_hold_no_worker_and_the_oldest_is_dropped() {
        let limits = Limits { workers: 1, fast_workers: 1, pending: 64, ..quick() };
        let limits = Limits { request_deadline: Duration::from_secs(30), ..limits };
        let (addr, _) = server(limits, 10);
        let silent: Vec<TcpStream> = (0..300)
            .map(|_| {
                let mut s = TcpStream::connect(&addr).unwrap();
                let _ = s.write_all(b"GET /api/info HTTP/1.1\r\n");
                s
            })
            .collect();
        let t = Instant::now();
        assert_eq!(ask(&addr, &get(&addr)), 200);
        assert!(t.elapsed() < Duration::from_secs(1), "{:?}", t.elapsed());
        drop(silent);
    }

    #[test]
    fn malformed_input_is_closed_at_once() {
        let limits = Limits { request_deadline: Duration::from_secs(5), ..quick() };
        let (addr, _) = server(limits, 10);
        let lf = format!("GET /x HTTP/1.1\nHost: {addr}\n\n");
        let hello = [0x16u8, 0x03, 0x01, 0x02, 0x00, 0x01, 0x00, 0x01, 0xfc, 0x03, 0x03];
        for (raw, code) in [(lf.as_bytes(), 400), (&hello[..], 400)] {
            let t = Instant::now();
            assert_eq!(ask(&addr, raw), code);
            assert!(t.elapsed() < Duration::from_secs(1), "{:?}", t.elapsed());
        }
        // An empty connection (closed without a byte) is closed at once, unanswered.
        let t = Instant::now();
        let mut s = TcpStream::connect(&addr).unwrap();
        s.shutdown(Shutdown::Write).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        let mut out = Vec::new();
        let _ = s.read_to_end(&mut out);
        assert!(out.is_empty() && t.elapsed() < Duration::from_secs(1), "{:?}", t.elapsed());
    }
}
