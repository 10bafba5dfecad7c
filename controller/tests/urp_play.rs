//! Playing a `.urp` through the in-process server: the dashboard's `load` and `play`, the
//! External Control node's fetch from a driver-side listener on 127.0.0.1 (read as the
//! URCap reads it: one line, then only what is already there), and the files a program
//! may read (only regular files inside `--programs`, each read once). Every wait is
//! bounded by `WAIT`, a hang guard.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use urscript_controller::net::{Ports, Server, ServerEvent, ServerOptions};

/// The hang guard of every wait.
const WAIT: Duration = Duration::from_secs(20);

/// A fresh directory under the system's temporary one.
fn temp_dir(tag: &str) -> PathBuf {
    static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    let dir = std::env::temp_dir().join(format!("urp-play-{}-{tag}-{n}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A plain-XML `.urp` whose main program is `nodes`, saved with `installation`.
fn urp_xml(name: &str, installation: &str, nodes: &str) -> String {
    format!(
        r#"<URProgram name="{name}" installation="{installation}" createdIn="5.21.0"><children>
  <MainProgram runOnlyOnce="true"><children>{nodes}</children></MainProgram>
</children></URProgram>"#
    )
}

const EXTERNAL_CONTROL: &str = r#"<Contributed strategyClass="com.fzi.externalcontrol.ExternalControlNode" strategyProgramNodeType="External Control"><dataModel/></Contributed>"#;

struct Setup {
    /// Kept running until the test ends.
    _server: Server,
    events: mpsc::Receiver<ServerEvent>,
    dashboard: (BufReader<TcpStream>, TcpStream),
}

/// A controller serving `programs`, its External Control nodes asking `urcap` (if
/// given), the arm RUNNING.
fn start(programs: &Path, urcap: Option<u16>) -> Setup {
    let (tx, rx) = mpsc::channel();
    let tx = std::sync::Mutex::new(tx);
    let server = Server::start(
        ServerOptions {
            ports: Ports::any(),
            programs: Some(programs.to_path_buf()),
            urcap_host: urcap.map(|p| ("127.0.0.1".to_string(), p)),
            ..ServerOptions::default()
        },
        move |e| {
            let _ = tx.lock().unwrap().send(e);
        },
    )
    .expect("start");
    let s = TcpStream::connect(server.addr("dashboard").unwrap()).unwrap();
    s.set_read_timeout(Some(WAIT)).unwrap();
    let mut r = BufReader::new(s.try_clone().unwrap());
    let mut greeting = String::new();
    r.read_line(&mut greeting).unwrap();
    let mut setup = Setup {
        _server: server,
        events: rx,
        dashboard: (r, s),
    };
    assert_eq!(setup.ask("brake release"), "Brake releasing");
    let start = Instant::now();
    while setup.ask("robotmode") != "Robotmode: RUNNING" {
        assert!(start.elapsed() < WAIT, "the arm never ran");
        std::thread::sleep(Duration::from_millis(20));
    }
    setup
}

impl Setup {
    fn ask(&mut self, cmd: &str) -> String {
        self.dashboard
            .1
            .write_all(format!("{cmd}\n").as_bytes())
            .unwrap();
        let mut line = String::new();
        self.dashboard.0.read_line(&mut line).unwrap();
        line.trim_end().to_string()
    }

    /// The next event `want` picks (others skipped), within the hang guard.
    fn wait_for(&self, what: &str, want: impl Fn(&ServerEvent) -> bool) -> ServerEvent {
        let start = Instant::now();
        loop {
            let left = WAIT.saturating_sub(start.elapsed());
            match self.events.recv_timeout(left) {
                Ok(e) if want(&e) => return e,
                Ok(_) => {}
                Err(_) => panic!("no {what} within {WAIT:?}"),
            }
        }
    }

    /// The texts of the program's messages until it ends, and how it ended.
    fn messages_until_end(&self) -> (Vec<String>, &'static str, Option<String>) {
        let mut texts = Vec::new();
        loop {
            match self.wait_for("program end", |e| {
                matches!(e, ServerEvent::Message(_))
                    || matches!(e, ServerEvent::Program { what, .. } if *what != "started")
            }) {
                ServerEvent::Message(m) => texts.push(m.text),
                ServerEvent::Program { what, text, .. } => return (texts, what, text),
                _ => unreachable!(),
            }
        }
    }
}

/// The driver's side, as UR's `ScriptSender` behaves: it reads `request_program\n`,
/// then `send` writes the reply on the connection, which stays open until the test
/// ends.
fn driver(send: impl FnOnce(&mut TcpStream) + Send + 'static) -> (u16, mpsc::Receiver<Vec<u8>>) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let Ok((mut s, _)) = listener.accept() else {
            return;
        };
        s.set_read_timeout(Some(WAIT)).unwrap();
        let mut request = [0u8; 16];
        if s.read_exact(&mut request).is_err() {
            return;
        }
        let _ = tx.send(request.to_vec());
        send(&mut s);
        // Open until the controller closes it (or the guard passes).
        let mut rest = [0u8; 64];
        let _ = s.read(&mut rest);
    });
    (port, rx)
}

fn play(setup: &mut Setup, name: &str) {
    assert_eq!(
        setup.ask(&format!("load {name}")),
        format!("Loading program: {name}")
    );
    assert_eq!(setup.ask("play"), "Starting program");
}

#[test]
fn a_script_sent_on_a_connection_the_driver_keeps_open_starts_the_program() {
    let dir = temp_dir("open");
    std::fs::write(
        dir.join("ec.urp"),
        urp_xml("ec", "default", EXTERNAL_CONTROL),
    )
    .unwrap();
    let (port, requests) = driver(|s| {
        s.write_all(b"textmsg(\"driven\")\nwrite_output_integer_register(1, 99)\n")
            .unwrap();
    });
    let mut setup = start(&dir, Some(port));
    let asked = Instant::now();
    play(&mut setup, "ec.urp");
    let started = setup.wait_for("program start", |e| {
        matches!(
            e,
            ServerEvent::Program {
                what: "started",
                ..
            }
        )
    });
    let took = asked.elapsed();
    assert!(
        matches!(&started, ServerEvent::Program { name, .. } if name == "ec.urp"),
        "{started:?}"
    );
    assert_eq!(
        requests.recv_timeout(WAIT).unwrap(),
        b"request_program\n",
        "the URCap's request"
    );
    let (texts, how, _) = setup.messages_until_end();
    assert_eq!(texts, ["driven"]);
    assert_eq!(how, "finished");
    // The speed is measured by `benches/urp_play.rs`; this only shows the figure.
    eprintln!("play to program start: {took:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The URCap reads its first line, then only the lines already received: what the
/// driver writes after a pause is not part of the program (with the connection still
/// open, a URCap on a robot gets the same).
#[test]
fn a_reply_written_in_two_parts_with_a_gap_gets_the_first_part_as_the_urcap_does() {
    let dir = temp_dir("gap");
    std::fs::write(
        dir.join("ec.urp"),
        urp_xml("ec", "default", EXTERNAL_CONTROL),
    )
    .unwrap();
    let (port, _requests) = driver(|s| {
        s.write_all(b"textmsg(\"first\")\ntextmsg(\"second\")\n")
            .unwrap();
        std::thread::sleep(Duration::from_millis(200));
        let _ = s.write_all(b"textmsg(\"late\")\n");
    });
    let mut setup = start(&dir, Some(port));
    play(&mut setup, "ec.urp");
    let (texts, how, why) = setup.messages_until_end();
    assert_eq!(texts, ["first", "second"], "{how}: {why:?}");
    assert_eq!(how, "finished");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A host that keeps talking (a line every 50 ms) never delays the program: it gets the
/// lines there when the first one is read.
#[test]
fn a_host_that_keeps_sending_does_not_hold_the_program_back() {
    let dir = temp_dir("chatty");
    std::fs::write(
        dir.join("ec.urp"),
        urp_xml("ec", "default", EXTERNAL_CONTROL),
    )
    .unwrap();
    let (port, _requests) = driver(|s| {
        let _ = s.write_all(b"textmsg(\"line 0\")\n");
        for k in 1..400 {
            std::thread::sleep(Duration::from_millis(50));
            if s.write_all(format!("textmsg(\"line {k}\")\n").as_bytes())
                .is_err()
            {
                return;
            }
        }
    });
    let mut setup = start(&dir, Some(port));
    play(&mut setup, "ec.urp");
    let (texts, how, why) = setup.messages_until_end();
    assert_eq!(texts, ["line 0"], "{how}: {why:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A line that started is waited for (up to the URCap's 500 ms per read): bytes of it
/// there make the reader "ready", and `readLine` blocks for its end.
#[test]
fn a_line_cut_in_two_is_waited_for() {
    let dir = temp_dir("cut");
    std::fs::write(
        dir.join("ec.urp"),
        urp_xml("ec", "default", EXTERNAL_CONTROL),
    )
    .unwrap();
    let (port, _requests) = driver(|s| {
        s.write_all(b"textmsg(\"first\")\ntextmsg(\"sec").unwrap();
        std::thread::sleep(Duration::from_millis(100));
        let _ = s.write_all(b"ond\")\n");
    });
    let mut setup = start(&dir, Some(port));
    play(&mut setup, "ec.urp");
    let (texts, how, why) = setup.messages_until_end();
    assert_eq!(texts, ["first", "second"], "{how}: {why:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The rest of a started line that does not come within 500 ms is the URCap's read
/// timeout: the program is its popup.
#[test]
fn a_line_whose_rest_never_comes_is_the_urcaps_timeout_popup() {
    let dir = temp_dir("stall");
    std::fs::write(
        dir.join("ec.urp"),
        urp_xml("ec", "default", EXTERNAL_CONTROL),
    )
    .unwrap();
    let (port, _requests) = driver(|s| {
        s.write_all(b"textmsg(\"first\")\ntextmsg(\"sec").unwrap();
    });
    let mut setup = start(&dir, Some(port));
    play(&mut setup, "ec.urp");
    let (texts, _, _) = setup.messages_until_end();
    assert_eq!(
        texts,
        [format!(
            "Timeout while reading requested program from 127.0.0.1:{port}"
        )]
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The refusal the play of a program ends in, within the hang guard.
fn refused(setup: &Setup) -> String {
    match setup.wait_for(
        "the refusal",
        |e| matches!(e, ServerEvent::Program { what, .. } if *what != "started"),
    ) {
        ServerEvent::Program {
            what: "refused",
            text: Some(text),
            ..
        } => text,
        other => panic!("not refused: {other:?}"),
    }
}

/// An installation whose External Control settings name `port` on 127.0.0.1.
fn installation(port: u16) -> String {
    format!(
        r#"<Installation><Contributions><URCaps><Contributed ownerId="com.fzi.externalcontrol" id="com.fzi.externalcontrol.impl.ExternalControlInstallationNodeService"><data key="host_ip" value="127.0.0.1"/><data key="port_nr" value="{port}"/></Contributed></URCaps></Contributions></Installation>"#
    )
}

/// A listener that must not be contacted: whether anyone connected.
fn bait() -> (TcpListener, u16) {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    l.set_nonblocking(true).unwrap();
    let port = l.local_addr().unwrap().port();
    (l, port)
}

fn contacted(l: &TcpListener) -> bool {
    l.accept().is_ok()
}

#[test]
fn an_installation_outside_the_programs_folder_is_not_read() {
    let dir = temp_dir("outside");
    let programs = dir.join("programs");
    let outside = dir.join("outside");
    std::fs::create_dir_all(&programs).unwrap();
    std::fs::create_dir_all(&outside).unwrap();
    let (listener, port) = bait();
    std::fs::write(outside.join("x.installation"), installation(port)).unwrap();
    let absolute = outside.join("x");
    for (name, saved_with) in [
        ("relative.urp", "../outside/x".to_string()),
        ("absolute.urp", absolute.display().to_string()),
    ] {
        std::fs::write(
            programs.join(name),
            urp_xml("ec", &saved_with, EXTERNAL_CONTROL),
        )
        .unwrap();
    }
    let mut setup = start(&programs, None);
    for name in ["relative.urp", "absolute.urp"] {
        play(&mut setup, name);
        let why = refused(&setup);
        assert!(
            why.contains("x.installation") && why.contains("outside the programs folder"),
            "{name}: {why}"
        );
    }
    assert!(!contacted(&listener), "the host of an outside installation");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_installation_elsewhere_inside_the_programs_folder_is_read() {
    let dir = temp_dir("inside");
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    let (port, requests) = driver(|s| {
        s.write_all(b"textmsg(\"driven\")\n").unwrap();
    });
    std::fs::write(dir.join("cell.installation"), installation(port)).unwrap();
    std::fs::write(
        dir.join("sub/ec.urp"),
        urp_xml("ec", "../cell", EXTERNAL_CONTROL),
    )
    .unwrap();
    let mut setup = start(&dir, None);
    play(&mut setup, "sub/ec.urp");
    let (texts, how, why) = setup.messages_until_end();
    assert_eq!(texts, ["driven"], "{how}: {why:?}");
    assert_eq!(requests.recv_timeout(WAIT).unwrap(), b"request_program\n");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A program swapped for a FIFO after `load` is refused at `play`, at once: opening it
/// for reading would wait for a writer forever.
#[cfg(unix)]
#[test]
fn a_program_swapped_for_a_fifo_is_refused_not_waited_on() {
    let dir = temp_dir("fifo");
    let path = dir.join("p.urp");
    std::fs::write(&path, urp_xml("p", "default", "<Halt/>")).unwrap();
    let mut setup = start(&dir, None);
    assert_eq!(setup.ask("load p.urp"), "Loading program: p.urp");
    std::fs::remove_file(&path).unwrap();
    let made = std::process::Command::new("mkfifo")
        .arg(&path)
        .status()
        .expect("mkfifo");
    assert!(made.success());
    assert_eq!(setup.ask("play"), "Starting program");
    let why = refused(&setup);
    assert!(why.contains("not a regular file"), "{why}");
    assert_eq!(setup.ask("programState"), "STOPPED p.urp");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A program swapped for a link to a file outside the programs folder after `load` is
/// refused at `play`.
#[cfg(unix)]
#[test]
fn a_program_swapped_for_a_link_out_of_the_folder_is_refused() {
    let dir = temp_dir("link");
    let programs = dir.join("programs");
    std::fs::create_dir_all(&programs).unwrap();
    let path = programs.join("p.urp");
    std::fs::write(&path, urp_xml("p", "default", "<Halt/>")).unwrap();
    let secret = dir.join("secret.urp");
    std::fs::write(&secret, urp_xml("secret", "default", "<Halt/>")).unwrap();
    let mut setup = start(&programs, None);
    assert_eq!(setup.ask("load p.urp"), "Loading program: p.urp");
    std::fs::remove_file(&path).unwrap();
    std::os::unix::fs::symlink(&secret, &path).unwrap();
    assert_eq!(setup.ask("play"), "Starting program");
    let why = refused(&setup);
    assert!(why.contains("outside the programs folder"), "{why}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A program that cannot be read is read and reported once.
#[test]
fn a_program_refused_is_reported_once() {
    let dir = temp_dir("once");
    std::fs::write(dir.join("bad.urp"), "not a program").unwrap();
    let mut setup = start(&dir, None);
    play(&mut setup, "bad.urp");
    let why = refused(&setup);
    assert!(why.starts_with("bad.urp: "), "{why}");
    // Another program run after it: every event of the refused one came before.
    std::fs::write(
        dir.join("good.urp"),
        urp_xml(
            "good",
            "default",
            r#"<Script type="Line"><expression>textmsg("ok")</expression></Script>"#,
        ),
    )
    .unwrap();
    play(&mut setup, "good.urp");
    let mut refusals = 0;
    loop {
        match setup.wait_for(
            "the good program's end",
            |e| matches!(e, ServerEvent::Program { what, .. } if *what != "started"),
        ) {
            ServerEvent::Program {
                what: "refused", ..
            } => refusals += 1,
            ServerEvent::Program { what, .. } => {
                assert_eq!(what, "finished");
                break;
            }
            _ => unreachable!(),
        }
    }
    assert_eq!(refusals, 0, "the bad program reported again");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A reply over `net::MAX_FETCHED` fails the play with the bound named. (One line, so
/// that the reader waits for all of it: lines after a pause would not be read.)
#[test]
fn a_reply_over_the_fetch_bound_fails_the_play() {
    use urscript_controller::net::MAX_FETCHED;
    let dir = temp_dir("huge");
    std::fs::write(
        dir.join("ec.urp"),
        urp_xml("ec", "default", EXTERNAL_CONTROL),
    )
    .unwrap();
    let (port, _requests) = driver(|s| {
        let _ = s.write_all(b"textmsg(\"");
        let _ = s.write_all(&vec![b'x'; MAX_FETCHED]);
    });
    let mut setup = start(&dir, Some(port));
    play(&mut setup, "ec.urp");
    let why = refused(&setup);
    assert_eq!(
        why,
        format!("ec.urp: the External Control reply is larger than {MAX_FETCHED} bytes")
    );
    let _ = std::fs::remove_dir_all(&dir);
}
