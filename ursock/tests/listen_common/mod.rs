//! Shared helpers of the `listen` tests: a listener child process with its output
//! collected by threads, and robot-side socket helpers. Every wait is bounded.
#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

pub const WAIT: Duration = Duration::from_secs(30);

/// The binary under test; `URSOCK_BIN` overrides it (to run these tests against another
/// build, e.g. the previous listener, and see them fail).
pub fn bin() -> String {
    std::env::var("URSOCK_BIN").unwrap_or_else(|_| env!("CARGO_BIN_EXE_ursock").to_string())
}

pub struct Listener {
    pub child: Child,
    pub addr: String,
    pub stdin: Option<ChildStdin>,
    out: Arc<Mutex<String>>,
    err: Arc<Mutex<String>>,
}

fn collect<R: Read + Send + 'static>(r: R, into: Arc<Mutex<String>>) {
    std::thread::spawn(move || {
        let mut lines = BufReader::new(r);
        let mut line = String::new();
        while lines.read_line(&mut line).map(|n| n > 0).unwrap_or(false) {
            into.lock().unwrap().push_str(&line);
            line.clear();
        }
    });
}

impl Listener {
    /// `ursock listen --bind 127.0.0.1 --port 0 ARGS`.
    pub fn start(args: &[&str]) -> Listener {
        let mut cmd = Command::new(bin());
        cmd.args(["listen", "--bind", "127.0.0.1", "--port", "0"])
            .args(args);
        Self::spawn(cmd)
    }

    /// [`Listener::start`] with environment variables set (`TZ`...).
    pub fn start_env(env: &[(&str, &str)], args: &[&str]) -> Listener {
        let mut cmd = Command::new(bin());
        cmd.args(["listen", "--bind", "127.0.0.1", "--port", "0"])
            .args(args)
            .envs(env.iter().copied());
        Self::spawn(cmd)
    }

    /// The same under `sh -c 'ulimit -n FDS; exec ursock listen ...'`.
    pub fn start_with_fd_limit(fds: u32, args: &[&str]) -> Listener {
        let mut script = format!("ulimit -n {fds} && exec \"$0\" listen --bind 127.0.0.1 --port 0");
        for a in args {
            script.push_str(&format!(" '{a}'"));
        }
        let mut cmd = Command::new("sh");
        cmd.args(["-c", &script, &bin()]);
        Self::spawn(cmd)
    }

    fn spawn(mut cmd: Command) -> Listener {
        let mut child = cmd
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn ursock listen");
        let mut stdout = BufReader::new(child.stdout.take().unwrap());
        let mut first = String::new();
        stdout.read_line(&mut first).unwrap();
        let first = first.trim_end().to_string();
        let addr = if let Some(a) = first.strip_prefix("listening on ") {
            a.to_string()
        } else {
            let v: serde_json::Value = serde_json::from_str(&first).expect(&first);
            v["addr"].as_str().expect(&first).to_string()
        };
        let out = Arc::new(Mutex::new(format!("{first}\n")));
        let err = Arc::new(Mutex::new(String::new()));
        collect(stdout, Arc::clone(&out));
        collect(child.stderr.take().unwrap(), Arc::clone(&err));
        let stdin = child.stdin.take();
        Listener {
            child,
            addr,
            stdin,
            out,
            err,
        }
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    pub fn stdout(&self) -> String {
        self.out.lock().unwrap().clone()
    }

    pub fn stderr(&self) -> String {
        self.err.lock().unwrap().clone()
    }

    /// Types a line on the listener's stdin.
    pub fn type_line(&mut self, line: &str) {
        let stdin = self.stdin.as_mut().unwrap();
        writeln!(stdin, "{line}").unwrap();
        stdin.flush().unwrap();
    }

    /// Waits until stdout (or stderr, `on_err`) contains `needle`; panics with both after
    /// [`WAIT`].
    pub fn wait_for(&self, needle: &str, on_err: bool) -> String {
        self.wait_for_n(needle, 1, on_err)
    }

    /// Waits until stdout (or stderr, `on_err`) contains `needle` `n` times; panics with
    /// both after [`WAIT`].
    pub fn wait_for_n(&self, needle: &str, n: usize, on_err: bool) -> String {
        let start = Instant::now();
        loop {
            let text = if on_err { self.stderr() } else { self.stdout() };
            if text.matches(needle).count() >= n {
                return text;
            }
            if start.elapsed() > WAIT {
                panic!(
                    "waited for {needle:?} ({n} times)\n--- stdout\n{}\n--- stderr\n{}",
                    self.stdout(),
                    self.stderr()
                );
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Waits for the process to exit by itself.
    pub fn wait_exit(&mut self) -> std::process::ExitStatus {
        let start = Instant::now();
        loop {
            if let Some(s) = self.child.try_wait().unwrap() {
                return s;
            }
            if start.elapsed() > WAIT {
                let _ = self.child.kill();
                panic!(
                    "listener did not exit\n--- stdout\n{}\n--- stderr\n{}",
                    self.stdout(),
                    self.stderr()
                );
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// (Threads, VmRSS in kB) from /proc/PID/status.
    pub fn threads_and_rss(&self) -> (u64, u64) {
        let status = std::fs::read_to_string(format!("/proc/{}/status", self.pid())).unwrap();
        let field = |name: &str| -> u64 {
            status
                .lines()
                .find_map(|l| l.strip_prefix(name))
                .and_then(|v| v.split_whitespace().next())
                .and_then(|v| v.parse().ok())
                .unwrap_or(0)
        };
        (field("Threads:"), field("VmRSS:"))
    }
}

impl Drop for Listener {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `ursock listen --bind 127.0.0.1 --port 0 ARGS` run to its end (stdin closed): its
/// exit status and output.
pub fn output(args: &[&str]) -> std::process::Output {
    Command::new(bin())
        .args(["listen", "--bind", "127.0.0.1", "--port", "0"])
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("run ursock listen")
}

/// A file of `text` in the temp dir (snippets, rules, a robot's program), named for
/// this process and `name`; removed on drop.
pub struct TempFile(std::path::PathBuf);

impl TempFile {
    pub fn new(name: &str, text: &str) -> TempFile {
        let p = std::env::temp_dir().join(format!("ursock-{}-{name}", std::process::id()));
        std::fs::write(&p, text).unwrap();
        TempFile(p)
    }

    pub fn path(&self) -> &str {
        self.0.to_str().unwrap()
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// A robot connection with a read timeout.
pub fn robot(addr: &str) -> TcpStream {
    let s = TcpStream::connect(addr).expect("connect");
    s.set_read_timeout(Some(WAIT)).unwrap();
    s.set_nodelay(true).unwrap();
    s
}

/// Reads until `n` bytes have come.
pub fn read_n(s: &mut TcpStream, n: usize) -> Vec<u8> {
    let mut buf = vec![0; n];
    s.read_exact(&mut buf).expect("reply");
    buf
}

/// Reads one LF-terminated line (LF included).
pub fn read_line(s: &mut TcpStream) -> String {
    let mut out = Vec::new();
    let mut b = [0u8; 1];
    loop {
        match s.read(&mut b) {
            Ok(0) => break,
            Ok(_) => {
                out.push(b[0]);
                if b[0] == b'\n' {
                    break;
                }
            }
            // A signal is not the end of the reply (read_exact retries the same way).
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => panic!("read: {e} after {:?}", String::from_utf8_lossy(&out)),
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Sends `request` and reads the reply line.
pub fn ask(addr: &str, request: &str) -> String {
    let mut s = robot(addr);
    s.write_all(request.as_bytes()).unwrap();
    read_line(&mut s)
}
