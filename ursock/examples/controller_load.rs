//! Load benchmark of `ursock controller` (the virtual Universal Robots controller).
//!
//! ```sh
//! cargo build --release -p ursock            # the binary under test
//! cargo run --release -p ursock --example controller_load [-- --seconds 30 --starts 20]
//! cargo run --release -p ursock --example controller_load -- --only fleet --fleet 16 --hog
//! ```
//!
//! The controller is the release `ursock` binary next to this example's directory
//! (`target/release/ursock`, found from the example's own path), or the one named by
//! `URSOCK_BIN`. When neither exists the example runs `cargo build --release -p ursock
//! --bin ursock` first. Every scenario starts a fresh controller on free ports
//! (`--json`, port 0 everywhere) and stops it afterwards.
//!
//! 1. Start-up: time from spawning the process to the dashboard's greeting line read by a
//!    client (repeated `--starts` times).
//! 2. One RTDE client (protocol 2, written here from UR's RTDE guide) with a 30-field
//!    output recipe at 500 Hz, recording every package for `--seconds`, while a program
//!    sent to the secondary port streams `servoj` targets every 2 ms (after a dashboard
//!    `power on` and `brake release`).
//! 3. The same with four RTDE clients at once, and with one RTDE client next to a
//!    realtime (30003) client that never reads.
//! 4. Idle: `--fleet` controllers with no client and no program, their CPU per second.
//! 5. Fleet: `--fleet` controllers at once, each with one RTDE client at 500 Hz (the
//!    30-field recipe, no program), all recording for `--seconds`.
//!
//! `--hog` runs a busy loop per core (`sh -c 'while :; do :; done'`) during every
//! scenario; `--realtime auto|off` is passed to each controller; `--client-realtime`
//! has each RTDE client's thread ask for `SCHED_FIFO` at the controllers' priority (10;
//! Linux, where allowed), so that with a busy neighbour the figures show the controller's
//! timing rather than a starved client's; `--only NAME[,NAME]` picks scenarios
//! (`startup`, `one`, `four`, `silent`, `idle`, `fleet`).
//!
//! For each run: packages received against expected, the inter-arrival period's
//! percentiles, the jitter `|period - 2 ms|`, the controller's `timestamp` deltas, the
//! controller's CPU time per second (`/proc/PID/stat`) and its peak RSS (`VmHWM`).
//! Linux only for the CPU and memory figures (elsewhere they read "n/a").

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

type Result<T> = std::result::Result<T, String>;

/// The 30 outputs of the recipe.
const FIELDS: [&str; 30] = [
    "timestamp",
    "actual_q",
    "actual_qd",
    "target_q",
    "actual_TCP_pose",
    "actual_TCP_speed",
    "robot_mode",
    "safety_mode",
    "runtime_state",
    "speed_scaling",
    "output_int_register_0",
    "output_int_register_1",
    "output_int_register_2",
    "output_int_register_3",
    "output_int_register_4",
    "output_int_register_5",
    "output_int_register_6",
    "output_int_register_7",
    "output_int_register_8",
    "output_int_register_9",
    "output_double_register_0",
    "output_double_register_1",
    "output_double_register_2",
    "output_double_register_3",
    "output_double_register_4",
    "output_double_register_5",
    "output_double_register_6",
    "output_double_register_7",
    "output_double_register_8",
    "output_double_register_9",
];

const FREQUENCY: f64 = 500.0;
const PERIOD_MS: f64 = 2.0;

/// The program streamed on the secondary port: joint 0 moves sinusoidally.
const PROGRAM: &str = "def stream():
  q0 = get_actual_joint_positions()
  t = 0.0
  while True:
    servoj([q0[0] + 0.3 * sin(t), q0[1], q0[2], q0[3], q0[4], q0[5]], t=0.002)
    t = t + 0.002
  end
end
";

struct Options {
    seconds: u64,
    starts: usize,
    /// Controllers of the idle and fleet scenarios.
    fleet: usize,
    /// A busy loop per core during every scenario.
    hog: bool,
    /// `--realtime` of each controller.
    realtime: String,
    /// The RTDE clients' threads ask for `SCHED_FIFO`.
    client_realtime: bool,
    /// The scenarios to run (all when empty).
    only: Vec<String>,
}

impl Options {
    fn runs(&self, name: &str) -> bool {
        self.only.is_empty() || self.only.iter().any(|o| o == name)
    }
}

fn main() {
    if let Err(e) = run() {
        eprintln!("controller_load: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<()> {
    let opts = parse_args()?;
    let bin = find_binary()?;
    println!("controller: {}", bin.display());
    println!("machine: {}", machine());
    println!(
        "controllers run with --realtime {}{}{}",
        opts.realtime,
        if opts.hog {
            "; a busy loop per core runs throughout"
        } else {
            ""
        },
        if opts.client_realtime {
            "; RTDE clients ask for SCHED_FIFO"
        } else {
            ""
        }
    );
    let _hog = opts.hog.then(Hog::start).transpose()?;
    println!();

    if opts.runs("startup") {
        startup(&bin, &opts)?;
    }
    for (name, title, clients, silent) in [
        (
            "one",
            "one RTDE client, 30 fields at 500 Hz, servoj streamed every 2 ms",
            1,
            false,
        ),
        ("four", "four RTDE clients at once", 4, false),
        (
            "silent",
            "one RTDE client and a realtime client that never reads",
            1,
            true,
        ),
    ] {
        if opts.runs(name) {
            println!();
            println!("## {title}");
            scenario(&bin, &opts, clients, silent)?;
        }
    }
    if opts.runs("idle") {
        println!();
        println!("## {} idle controllers (no client, no program)", opts.fleet);
        idle(&bin, &opts)?;
    }
    if opts.runs("fleet") {
        println!();
        println!(
            "## {} controllers, one RTDE client at 500 Hz each (30 fields, no program)",
            opts.fleet
        );
        fleet(&bin, &opts)?;
    }
    Ok(())
}

fn parse_args() -> Result<Options> {
    let mut opts = Options {
        seconds: 30,
        starts: 20,
        fleet: 8,
        hog: false,
        realtime: "auto".into(),
        client_realtime: false,
        only: Vec::new(),
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or_else(|| format!("{a} needs a value"));
        let number = |v: String| -> Result<u64> {
            v.parse()
                .map_err(|_| format!("{a} needs a positive number, not {v:?}"))
        };
        match a.as_str() {
            "--seconds" => opts.seconds = number(value()?)?.max(1),
            "--starts" => opts.starts = number(value()?)?.max(1) as usize,
            "--fleet" => opts.fleet = number(value()?)?.clamp(1, 256) as usize,
            "--hog" => opts.hog = true,
            "--client-realtime" => opts.client_realtime = true,
            "--realtime" => {
                opts.realtime = value()?;
                if !["auto", "off"].contains(&opts.realtime.as_str()) {
                    return Err(format!("--realtime auto|off, not {:?}", opts.realtime));
                }
            }
            "--only" => opts.only = value()?.split(',').map(str::to_string).collect(),
            "-h" | "--help" => {
                println!(
                    "controller_load [--seconds N (30)] [--starts N (20)] [--fleet N (8)] \
                     [--hog] [--realtime auto|off] [--client-realtime] \
                     [--only startup,one,four,silent,idle,fleet]"
                );
                std::process::exit(0);
            }
            _ => return Err(format!("unknown argument {a:?}")),
        }
    }
    Ok(opts)
}

/// `URSOCK_BIN`, else `ursock` in the profile directory above `examples/`, else built.
fn find_binary() -> Result<PathBuf> {
    if let Some(p) = std::env::var_os("URSOCK_BIN") {
        return Ok(PathBuf::from(p));
    }
    let exe = std::env::current_exe().map_err(|e| format!("own path: {e}"))?;
    let profile_dir = exe
        .parent()
        .and_then(|p| p.parent())
        .ok_or("cannot find the target directory")?;
    let bin = profile_dir.join(format!("ursock{}", std::env::consts::EXE_SUFFIX));
    if !bin.exists() {
        println!("{} missing: cargo build --release -p ursock", bin.display());
        let status = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
            .args(["build", "--release", "-p", "ursock", "--bin", "ursock"])
            .status()
            .map_err(|e| format!("cargo build: {e}"))?;
        if !status.success() || !bin.exists() {
            return Err(format!("cargo build did not produce {}", bin.display()));
        }
    }
    Ok(bin)
}

fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(0);
    let kernel = std::fs::read_to_string("/proc/sys/kernel/osrelease")
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|_| "?".into());
    format!("{cores} cores, {cpu}, Linux {kernel}")
}

/// A running controller and the addresses of its servers.
struct Controller {
    child: Child,
    /// Steps the controller computed late, summed over its `late` events.
    late_steps: Arc<AtomicU64>,
    dashboard: SocketAddr,
    secondary: SocketAddr,
    realtime: SocketAddr,
    rtde: SocketAddr,
}

impl Controller {
    /// Spawns the controller; returns once the dashboard is listening (or, with
    /// `all`, all five servers).
    fn start(bin: &PathBuf, realtime: &str, all: bool) -> Result<Controller> {
        let mut child = Command::new(bin)
            .args(["controller", "--json", "--realtime", realtime])
            .args(["--dashboard-port", "0", "--primary-port", "0"])
            .args(["--secondary-port", "0", "--realtime-port", "0"])
            .args(["--rtde-port", "0", "--interpreter-port", "0"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| format!("cannot start {}: {e}", bin.display()))?;
        let stdout = child.stdout.take().ok_or("no stdout")?;
        let mut out = BufReader::new(stdout);
        let mut addrs: Vec<(String, SocketAddr)> = Vec::new();
        let wanted = if all { 6 } else { 1 };
        let mut line = String::new();
        let outcome = loop {
            line.clear();
            match out.read_line(&mut line) {
                Ok(0) => break Err("the controller ended before listening".to_string()),
                Ok(_) => {}
                Err(e) => break Err(format!("controller output: {e}")),
            }
            let Ok(v) = serde_json::from_str::<serde_json::Value>(&line) else {
                continue;
            };
            if v["event"] != "listening" {
                continue;
            }
            let (Some(service), Some(addr)) = (v["service"].as_str(), v["addr"].as_str()) else {
                break Err(format!("listening event without service/addr: {line}"));
            };
            let Ok(addr) = addr.parse::<SocketAddr>() else {
                break Err(format!("bad address in {line}"));
            };
            addrs.push((service.to_string(), addr));
            let have_dashboard = addrs.iter().any(|(s, _)| s == "dashboard");
            if (all && addrs.len() >= wanted) || (!all && have_dashboard) {
                break Ok(());
            }
        };
        if let Err(e) = outcome {
            let _ = child.kill();
            let _ = child.wait();
            return Err(e);
        }
        // Keep draining the events so the controller never blocks on a full pipe; the
        // `late` events are counted.
        let late_steps = Arc::new(AtomicU64::new(0));
        let late = Arc::clone(&late_steps);
        std::thread::spawn(move || {
            let mut line = String::new();
            while out.read_line(&mut line).map(|n| n > 0).unwrap_or(false) {
                if line.contains("\"late\"") {
                    if let Ok(v) = serde_json::from_str::<serde_json::Value>(&line) {
                        late.fetch_add(v["late_steps"].as_u64().unwrap_or(0), Ordering::Relaxed);
                    }
                }
                line.clear();
            }
        });
        let find = |name: &str| {
            addrs
                .iter()
                .find(|(s, _)| s == name)
                .map(|(_, a)| *a)
                .unwrap_or_else(|| SocketAddr::from(([127, 0, 0, 1], 0)))
        };
        Ok(Controller {
            late_steps,
            dashboard: find("dashboard"),
            secondary: find("secondary"),
            realtime: find("realtime"),
            rtde: find("rtde"),
            child,
        })
    }

    fn pid(&self) -> u32 {
        self.child.id()
    }
}

impl Drop for Controller {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Connects to a server on the loopback (a wildcard listening address is reached there).
fn connect(addr: SocketAddr) -> Result<TcpStream> {
    let addr = if addr.ip().is_unspecified() {
        SocketAddr::from(([127, 0, 0, 1], addr.port()))
    } else {
        addr
    };
    let s = TcpStream::connect_timeout(&addr, Duration::from_secs(5))
        .map_err(|e| format!("connect {addr}: {e}"))?;
    let _ = s.set_nodelay(true);
    Ok(s)
}

// ---------------------------------------------------------------------------------------
// Dashboard

struct Dashboard {
    stream: TcpStream,
    reader: BufReader<TcpStream>,
}

impl Dashboard {
    fn connect(addr: SocketAddr) -> Result<(Dashboard, String)> {
        let stream = connect(addr)?;
        let _ = stream.set_read_timeout(Some(Duration::from_secs(5)));
        let reader = BufReader::new(stream.try_clone().map_err(|e| e.to_string())?);
        let mut d = Dashboard { stream, reader };
        let greeting = d.line()?;
        Ok((d, greeting))
    }

    fn line(&mut self) -> Result<String> {
        let mut line = String::new();
        match self.reader.read_line(&mut line) {
            Ok(0) => Err("dashboard closed".into()),
            Ok(_) => Ok(line.trim_end().to_string()),
            Err(e) => Err(format!("dashboard: {e}")),
        }
    }

    fn ask(&mut self, command: &str) -> Result<String> {
        self.stream
            .write_all(format!("{command}\n").as_bytes())
            .map_err(|e| format!("dashboard: {e}"))?;
        self.line()
    }

    fn wait_for(&mut self, command: &str, answer: &str) -> Result<()> {
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            let got = self.ask(command)?;
            if got == answer {
                return Ok(());
            }
            if Instant::now() > deadline {
                return Err(format!("{command}: {got:?}, waited for {answer:?}"));
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

// ---------------------------------------------------------------------------------------
// 1. Start-up

fn startup(bin: &PathBuf, opts: &Options) -> Result<()> {
    let starts = opts.starts;
    println!("## start-up: spawn to the dashboard's greeting read by a client ({starts} starts)");
    let mut times = Vec::with_capacity(starts);
    let mut greeting = String::new();
    for _ in 0..starts {
        let t0 = Instant::now();
        let c = Controller::start(bin, &opts.realtime, false)?;
        let (_d, g) = Dashboard::connect(c.dashboard)?;
        times.push(ms(t0.elapsed()));
        greeting = g;
        drop(c);
    }
    times.sort_by(f64::total_cmp);
    println!("greeting: {greeting:?}");
    println!(
        "start-up ms: min {:.2}  p50 {:.2}  max {:.2}",
        times[0],
        pct(&times, 50.0),
        times[times.len() - 1]
    );
    Ok(())
}

// ---------------------------------------------------------------------------------------
// RTDE client (protocol 2)

fn rtde_send(s: &mut TcpStream, kind: u8, payload: &[u8]) -> Result<()> {
    let size = 3 + payload.len();
    let size = u16::try_from(size).map_err(|_| "RTDE packet too long".to_string())?;
    let mut p = Vec::with_capacity(size as usize);
    p.extend_from_slice(&size.to_be_bytes());
    p.push(kind);
    p.extend_from_slice(payload);
    s.write_all(&p).map_err(|e| format!("rtde send: {e}"))
}

/// One packet: its type and payload.
fn rtde_recv(s: &mut TcpStream, payload: &mut Vec<u8>) -> Result<u8> {
    let mut head = [0u8; 3];
    s.read_exact(&mut head)
        .map_err(|e| format!("rtde receive: {e}"))?;
    let size = u16::from_be_bytes([head[0], head[1]]) as usize;
    if size < 3 {
        return Err(format!("rtde: packet size {size}"));
    }
    payload.resize(size - 3, 0);
    s.read_exact(payload)
        .map_err(|e| format!("rtde receive: {e}"))?;
    Ok(head[2])
}

/// The reply of type `kind`, skipping text messages and data packages.
fn rtde_reply(s: &mut TcpStream, kind: u8) -> Result<Vec<u8>> {
    let mut payload = Vec::new();
    loop {
        let t = rtde_recv(s, &mut payload)?;
        if t == kind {
            return Ok(payload);
        }
        if t != b'M' && t != b'U' {
            return Err(format!(
                "rtde: expected {:?}, got {:?}",
                kind as char, t as char
            ));
        }
    }
}

fn type_size(t: &str) -> Option<usize> {
    Some(match t {
        "BOOL" | "UINT8" => 1,
        "UINT32" | "INT32" => 4,
        "UINT64" | "DOUBLE" => 8,
        "VECTOR3D" => 24,
        "VECTOR6D" => 48,
        "VECTOR6INT32" | "VECTOR6UINT32" => 24,
        _ => return None,
    })
}

/// A started RTDE client: its stream, its recipe id and the package size.
struct Rtde {
    stream: TcpStream,
    recipe: u8,
    package: usize,
    /// Offset of `actual_q` in the payload after the recipe id.
    q_offset: usize,
}

impl Rtde {
    fn start(addr: SocketAddr) -> Result<Rtde> {
        let mut s = connect(addr)?;
        let _ = s.set_read_timeout(Some(Duration::from_secs(5)));
        rtde_send(&mut s, b'V', &2u16.to_be_bytes())?;
        let r = rtde_reply(&mut s, b'V')?;
        if r.first() != Some(&1) {
            return Err("rtde: protocol version 2 refused".into());
        }
        let mut setup = FREQUENCY.to_be_bytes().to_vec();
        setup.extend_from_slice(FIELDS.join(",").as_bytes());
        rtde_send(&mut s, b'O', &setup)?;
        let r = rtde_reply(&mut s, b'O')?;
        let (&recipe, types) = r.split_first().ok_or("rtde: empty setup reply")?;
        let types = String::from_utf8_lossy(types).to_string();
        let types: Vec<&str> = types.split(',').collect();
        if recipe == 0 || types.len() != FIELDS.len() {
            return Err(format!("rtde: setup refused: recipe {recipe}, {types:?}"));
        }
        let mut package = 0;
        let mut q_offset = 0;
        for (name, t) in FIELDS.iter().zip(&types) {
            if *name == "actual_q" {
                q_offset = package;
            }
            package += type_size(t).ok_or_else(|| format!("rtde: {name} is {t}"))?;
        }
        if types[0] != "DOUBLE" {
            return Err(format!("rtde: timestamp is {}", types[0]));
        }
        rtde_send(&mut s, b'S', &[])?;
        let r = rtde_reply(&mut s, b'S')?;
        if r.first() != Some(&1) {
            return Err("rtde: start refused".into());
        }
        Ok(Rtde {
            stream: s,
            recipe,
            package,
            q_offset,
        })
    }

    /// Records every data package until `end`.
    fn record(mut self, end: Instant) -> Result<Record> {
        let mut rec = Record::default();
        let mut payload = Vec::with_capacity(1024);
        loop {
            let t = rtde_recv(&mut self.stream, &mut payload)?;
            let at = Instant::now();
            if at > end {
                return Ok(rec);
            }
            if t != b'U' {
                continue;
            }
            if payload.len() != 1 + self.package || payload[0] != self.recipe {
                return Err(format!(
                    "rtde: data package of {} bytes for recipe {}",
                    payload.len(),
                    payload[0]
                ));
            }
            let f = |o: usize| {
                let mut b = [0u8; 8];
                b.copy_from_slice(&payload[1 + o..9 + o]);
                f64::from_be_bytes(b)
            };
            rec.arrivals.push(at);
            rec.timestamps.push(f(0));
            let q0 = f(self.q_offset);
            rec.q0_min = rec.q0_min.min(q0);
            rec.q0_max = rec.q0_max.max(q0);
        }
    }
}

struct Record {
    arrivals: Vec<Instant>,
    timestamps: Vec<f64>,
    q0_min: f64,
    q0_max: f64,
}

impl Default for Record {
    fn default() -> Self {
        Record {
            arrivals: Vec::with_capacity(20_000),
            timestamps: Vec::with_capacity(20_000),
            q0_min: f64::INFINITY,
            q0_max: f64::NEG_INFINITY,
        }
    }
}

/// The calling thread asks for `SCHED_FIFO` at the controllers' priority (a refusal
/// leaves it as it was; it is said once in the header).
fn client_fifo() {
    #[cfg(target_os = "linux")]
    {
        use thread_priority::unix::{
            set_thread_priority_and_policy, thread_native_id, RealtimeThreadSchedulePolicy,
            ThreadSchedulePolicy,
        };
        use thread_priority::{ThreadPriority, ThreadPriorityValue};
        if let Ok(p) = ThreadPriorityValue::try_from(urscript_controller::net::FIFO_PRIORITY) {
            let _ = set_thread_priority_and_policy(
                thread_native_id(),
                ThreadPriority::Crossplatform(p),
                ThreadSchedulePolicy::Realtime(RealtimeThreadSchedulePolicy::Fifo),
            );
        }
    }
}

/// Each client records until `end` in a thread of its own (at `SCHED_FIFO` if `fifo`);
/// their records, in order.
fn record_all(clients: Vec<Rtde>, end: Instant, fifo: bool) -> Result<Vec<Record>> {
    let handles: Vec<_> = clients
        .into_iter()
        .map(|r| {
            std::thread::spawn(move || {
                if fifo {
                    client_fifo();
                }
                r.record(end)
            })
        })
        .collect();
    let mut records = Vec::new();
    for h in handles {
        records.push(h.join().map_err(|_| "an RTDE client thread failed")??);
    }
    Ok(records)
}

// ---------------------------------------------------------------------------------------
// 2 and 3. Streaming under load

fn scenario(
    bin: &PathBuf,
    opts: &Options,
    rtde_clients: usize,
    silent_realtime: bool,
) -> Result<()> {
    let seconds = opts.seconds;
    let c = Controller::start(bin, &opts.realtime, true)?;
    let (mut d, _) = Dashboard::connect(c.dashboard)?;
    d.ask("power on")?;
    d.wait_for("robotmode", "Robotmode: IDLE")?;
    d.ask("brake release")?;
    d.wait_for("robotmode", "Robotmode: RUNNING")?;

    // The program, on the secondary port; its state packages are read and dropped.
    let mut secondary = connect(c.secondary)?;
    secondary
        .write_all(PROGRAM.as_bytes())
        .map_err(|e| format!("secondary: {e}"))?;
    let stop = Arc::new(AtomicBool::new(false));
    let drain = {
        let mut s = secondary.try_clone().map_err(|e| e.to_string())?;
        let _ = s.set_read_timeout(Some(Duration::from_millis(200)));
        let stop = stop.clone();
        std::thread::spawn(move || {
            let mut buf = [0u8; 16 * 1024];
            while !stop.load(Ordering::Relaxed) {
                match s.read(&mut buf) {
                    Ok(0) => break,
                    Ok(_) => {}
                    Err(e)
                        if matches!(
                            e.kind(),
                            std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                        ) => {}
                    Err(_) => break,
                }
            }
        })
    };
    d.wait_for("running", "Program running: true")?;

    // The realtime client that never reads (connected before the RTDE clients).
    let realtime = if silent_realtime {
        Some(connect(c.realtime)?)
    } else {
        None
    };

    let clients = (0..rtde_clients)
        .map(|_| Rtde::start(c.rtde))
        .collect::<Result<Vec<_>>>()?;
    let cpu0 = cpu_seconds(c.pid());
    let t0 = Instant::now();
    let end = t0 + Duration::from_secs(seconds);
    let records = record_all(clients, end, opts.client_realtime)?;
    let wall = t0.elapsed().as_secs_f64();
    let cpu1 = cpu_seconds(c.pid());
    let hwm = peak_rss_kib(c.pid());
    let still_running = d.ask("running")?;

    let mut waiting = 0usize;
    if let Some(mut rt) = realtime {
        // What the controller managed to push to the client that never read.
        let _ = rt.set_nonblocking(true);
        let mut buf = [0u8; 64 * 1024];
        while let Ok(n) = rt.read(&mut buf) {
            if n == 0 {
                break;
            }
            waiting += n;
        }
    }
    stop.store(true, Ordering::Relaxed);
    let _ = secondary.shutdown(std::net::Shutdown::Both);
    let _ = drain.join();

    let expected = (seconds as f64 * FREQUENCY).round() as usize;
    for (i, r) in records.iter().enumerate() {
        report_record(i, r, expected);
    }
    match (cpu0, cpu1) {
        (Some(a), Some(b)) => println!(
            "controller CPU: {:.1} ms per second of run ({:.2} % of one core)",
            (b - a) / wall * 1000.0,
            (b - a) / wall * 100.0
        ),
        _ => println!("controller CPU: n/a"),
    }
    match hwm {
        Some(k) => println!("controller peak RSS (VmHWM): {:.1} MiB", k as f64 / 1024.0),
        None => println!("controller peak RSS: n/a"),
    }
    if silent_realtime {
        println!("realtime client that never read: {waiting} bytes were waiting for it");
    }
    println!(
        "controller late steps (its `late` events): {}",
        c.late_steps.load(Ordering::Relaxed)
    );
    println!("dashboard after the run: {still_running}");
    println!(
        "host load average at the end (1, 5, 15 min): {}",
        load_average()
    );
    Ok(())
}

fn report_record(i: usize, r: &Record, expected: usize) {
    let n = r.arrivals.len();
    println!(
        "client {i}: packages {n} / {expected} expected; actual_q[0] moved over {:.3}..{:.3} rad",
        r.q0_min, r.q0_max
    );
    if n < 2 {
        return;
    }
    let mut periods: Vec<f64> = r.arrivals.windows(2).map(|w| ms(w[1] - w[0])).collect();
    let mut jitter: Vec<f64> = periods.iter().map(|p| (p - PERIOD_MS).abs()).collect();
    periods.sort_by(f64::total_cmp);
    jitter.sort_by(f64::total_cmp);
    println!(
        "  period ms: p50 {:.3}  p99 {:.3}  p99.9 {:.3}  max {:.3}",
        pct(&periods, 50.0),
        pct(&periods, 99.0),
        pct(&periods, 99.9),
        periods[periods.len() - 1]
    );
    println!(
        "  jitter |period - 2 ms| ms: p50 {:.3}  p99 {:.3}  (> 1 ms: {})",
        pct(&jitter, 50.0),
        pct(&jitter, 99.0),
        jitter.iter().filter(|j| **j > 1.0).count()
    );
    // The controller's timestamps: whole steps of 2 ms between packages (a gap of two
    // or more steps is a package the controller skipped), and how many deltas are not
    // an exact multiple of 2 ms (a clock that is not counted in steps).
    let mut steps = [0usize; 3]; // one step, two, three or more
    let mut inexact = 0usize;
    for w in r.timestamps.windows(2) {
        let n = (w[1] - w[0]) / 0.002;
        let whole = n.round();
        if (n - whole).abs() > 1e-6 {
            inexact += 1;
        }
        if whole <= 1.0 {
            steps[0] += 1;
        } else if whole <= 2.0 {
            steps[1] += 1;
        } else {
            steps[2] += 1;
        }
    }
    let (skipped, _, _) = stream_figures(r);
    println!(
        "  timestamp deltas (nearest step): 2 ms {}, 4 ms {}, 6 ms+ {}; steps skipped {skipped}; not an exact multiple of 2 ms {inexact}",
        steps[0], steps[1], steps[2]
    );
}

// ---------------------------------------------------------------------------------------
// 4 and 5. Idle controllers and a fleet

fn idle(bin: &PathBuf, opts: &Options) -> Result<()> {
    let controllers = (0..opts.fleet)
        .map(|_| Controller::start(bin, &opts.realtime, true))
        .collect::<Result<Vec<_>>>()?;
    // Past start-up.
    std::thread::sleep(Duration::from_secs(1));
    let cpu0: Vec<_> = controllers.iter().map(|c| cpu_seconds(c.pid())).collect();
    let t0 = Instant::now();
    std::thread::sleep(Duration::from_secs(opts.seconds));
    let wall = t0.elapsed().as_secs_f64();
    let mut shares = Vec::new();
    for (c, a) in controllers.iter().zip(cpu0) {
        if let (Some(a), Some(b)) = (a, cpu_seconds(c.pid())) {
            shares.push((b - a) / wall * 100.0);
        }
    }
    shares.sort_by(f64::total_cmp);
    if shares.is_empty() {
        println!("idle CPU: n/a");
    } else {
        println!(
            "idle CPU per controller, % of one core: min {:.2}  p50 {:.2}  max {:.2} (sum {:.2})",
            shares[0],
            pct(&shares, 50.0),
            shares[shares.len() - 1],
            shares.iter().sum::<f64>()
        );
    }
    let rss: Vec<u64> = controllers
        .iter()
        .filter_map(|c| peak_rss_kib(c.pid()))
        .collect();
    if let Some(max) = rss.iter().max() {
        println!(
            "peak RSS per controller: max {:.1} MiB",
            *max as f64 / 1024.0
        );
    }
    println!("host load average (1, 5, 15 min): {}", load_average());
    Ok(())
}

fn fleet(bin: &PathBuf, opts: &Options) -> Result<()> {
    let controllers = (0..opts.fleet)
        .map(|_| Controller::start(bin, &opts.realtime, true))
        .collect::<Result<Vec<_>>>()?;
    let clients = controllers
        .iter()
        .map(|c| Rtde::start(c.rtde))
        .collect::<Result<Vec<_>>>()?;
    let cpu0: Vec<_> = controllers.iter().map(|c| cpu_seconds(c.pid())).collect();
    let late0: Vec<u64> = controllers
        .iter()
        .map(|c| c.late_steps.load(Ordering::Relaxed))
        .collect();
    let t0 = Instant::now();
    let end = t0 + Duration::from_secs(opts.seconds);
    let records = record_all(clients, end, opts.client_realtime)?;
    let wall = t0.elapsed().as_secs_f64();
    let expected = (opts.seconds as f64 * FREQUENCY).round() as usize;
    println!("controller  packages/expected  skipped  late steps  jitter p99 ms  max gap ms  CPU %  RSS MiB");
    let (mut skipped_all, mut late_all, mut worst_p99, mut cpu_all) = (0u64, 0u64, 0.0f64, 0.0);
    let mut fewest = usize::MAX;
    for (i, (c, r)) in controllers.iter().zip(&records).enumerate() {
        let (skipped, p99, max_gap) = stream_figures(r);
        let late = c.late_steps.load(Ordering::Relaxed) - late0[i];
        let cpu = match (cpu0[i], cpu_seconds(c.pid())) {
            (Some(a), Some(b)) => (b - a) / wall * 100.0,
            _ => f64::NAN,
        };
        let rss = peak_rss_kib(c.pid()).map_or(f64::NAN, |k| k as f64 / 1024.0);
        println!(
            "{i:>10}  {:>8}/{expected:<8}  {skipped:>7}  {late:>10}  {p99:>13.3}  {max_gap:>10.3}  {cpu:>5.2}  {rss:>7.1}",
            r.arrivals.len()
        );
        skipped_all += skipped;
        late_all += late;
        worst_p99 = worst_p99.max(p99);
        cpu_all += cpu;
        fewest = fewest.min(r.arrivals.len());
    }
    println!(
        "fleet of {}: fewest packages {fewest}/{expected}, steps skipped {skipped_all}, late steps {late_all}, worst jitter p99 {worst_p99:.3} ms, CPU {cpu_all:.1} % of one core in all",
        opts.fleet
    );
    println!("host load average (1, 5, 15 min): {}", load_average());
    Ok(())
}

/// Of one client's record: the steps the controller skipped (timestamp gaps past one
/// step), the arrival jitter's p99 and the longest gap between arrivals, in ms.
fn stream_figures(r: &Record) -> (u64, f64, f64) {
    let skipped: u64 = r
        .timestamps
        .windows(2)
        .map(|w| ((w[1] - w[0]) / 0.002).round() - 1.0)
        .filter(|s| *s > 0.0)
        .map(|s| s as u64)
        .sum();
    let mut jitter: Vec<f64> = r
        .arrivals
        .windows(2)
        .map(|w| (ms(w[1] - w[0]) - PERIOD_MS).abs())
        .collect();
    jitter.sort_by(f64::total_cmp);
    let max_gap = r
        .arrivals
        .windows(2)
        .map(|w| ms(w[1] - w[0]))
        .fold(0.0, f64::max);
    let p99 = if jitter.is_empty() {
        f64::NAN
    } else {
        pct(&jitter, 99.0)
    };
    (skipped, p99, max_gap)
}

/// A busy loop per core, in processes of their own, until dropped.
struct Hog(Vec<Child>);

impl Hog {
    fn start() -> Result<Hog> {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let children = (0..cores)
            .map(|_| {
                Command::new("sh")
                    .args(["-c", "while :; do :; done"])
                    .stdin(Stdio::null())
                    .spawn()
                    .map_err(|e| format!("cannot start a busy loop: {e}"))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Hog(children))
    }
}

impl Drop for Hog {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

// ---------------------------------------------------------------------------------------
// Helpers

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1000.0
}

/// Nearest-rank percentile of sorted values.
fn pct(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let rank = ((p / 100.0) * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// The host's load average, from `/proc/loadavg` (other work competes for the CPUs).
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "n/a".into())
}

/// utime + stime of a process, in seconds (Linux).
fn cpu_seconds(pid: u32) -> Option<f64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // The command name may hold spaces: fields are counted after its closing ')'.
    let rest = &stat[stat.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // Fields 14 and 15 of proc(5); field 3 is rest's first.
    let utime: u64 = fields.get(11)?.parse().ok()?;
    let stime: u64 = fields.get(12)?.parse().ok()?;
    Some((utime + stime) as f64 / clock_ticks())
}

/// `getconf CLK_TCK`, 100 when it cannot be asked.
fn clock_ticks() -> f64 {
    Command::new("getconf")
        .arg("CLK_TCK")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|s| s.trim().parse::<f64>().ok())
        .filter(|t| *t > 0.0)
        .unwrap_or(100.0)
}

/// VmHWM of a process in KiB (Linux).
fn peak_rss_kib(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()
}
