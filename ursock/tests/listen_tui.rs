//! `ursock listen --tui` in a real terminal: tmux runs it, a robot connects over
//! loopback, keys are sent and the pane is captured. Skips (and says why) without tmux.

mod listen_common;

use std::io::Write;
use std::process::Command;
use std::time::{Duration, Instant};

use listen_common::{read_line, read_n, robot, WAIT};

struct Tmux {
    socket: String,
    session: String,
}

impl Tmux {
    fn cmd(&self, args: &[&str]) -> std::process::Output {
        Command::new("tmux")
            .args(["-L", &self.socket])
            .args(args)
            .env("TERM", "xterm-256color")
            .output()
            .expect("tmux")
    }

    fn capture(&self) -> String {
        let out = self.cmd(&["capture-pane", "-p", "-t", &self.session]);
        String::from_utf8_lossy(&out.stdout).into_owned()
    }

    fn wait_for(&self, needle: &str) -> String {
        let start = Instant::now();
        loop {
            let pane = self.capture();
            if pane.contains(needle) {
                return pane;
            }
            assert!(
                start.elapsed() < WAIT,
                "waited for {needle:?} in the pane:\n{pane}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Waits until `test` holds for the pane; the pane it held for.
    fn wait_until(&self, what: &str, test: impl Fn(&str) -> bool) -> String {
        let start = Instant::now();
        loop {
            let pane = self.capture();
            if test(&pane) {
                return pane;
            }
            assert!(
                start.elapsed() < WAIT,
                "waited for {what} in the pane:\n{pane}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// The status line's rows (below the input box) joined: the text as one line, the
    /// way it was wrapped (trailing spaces kept, `-N`).
    fn status(&self) -> String {
        let out = self.cmd(&["capture-pane", "-p", "-N", "-t", &self.session]);
        let pane = String::from_utf8_lossy(&out.stdout).into_owned();
        let rows: Vec<&str> = pane.lines().collect();
        let after = rows
            .iter()
            .rposition(|r| r.starts_with('└'))
            .map_or(0, |i| i + 1);
        rows[after..].concat().trim_end().to_string()
    }

    fn keys(&self, literal: &str) {
        self.cmd(&["send-keys", "-t", &self.session, "-l", literal]);
    }

    fn key(&self, name: &str) {
        self.cmd(&["send-keys", "-t", &self.session, name]);
    }
}

impl Drop for Tmux {
    fn drop(&mut self) {
        let _ = self.cmd(&["kill-server"]);
    }
}

fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    l.local_addr().unwrap().port()
}

fn tmux_missing() -> bool {
    if Command::new("tmux").arg("-V").output().is_err() {
        println!("skipped: tmux is not installed (apt-get install tmux)");
        return true;
    }
    false
}

/// `ursock listen --tui ... ARGS` in a new 150x30 tmux session on its own server.
fn start(name: &str, port: u16, args: &str) -> Tmux {
    let t = Tmux {
        socket: format!("ursock-test-{}-{name}", std::process::id()),
        session: "listen".into(),
    };
    let command = format!(
        "{} listen --tui --bind 127.0.0.1 --port {port} {args}",
        listen_common::bin()
    );
    let out = t.cmd(&[
        "new-session",
        "-d",
        "-s",
        &t.session,
        "-x",
        "150",
        "-y",
        "30",
        &command,
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    t.wait_for("robots (Up/Down)");
    t
}

/// The count in the title "N new lines below".
fn new_below(pane: &str) -> u64 {
    let at = pane.find(" new lines below").expect("scrolled back");
    let digits: String = pane[..at]
        .chars()
        .rev()
        .take_while(char::is_ascii_digit)
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .collect();
    digits.parse().unwrap()
}

#[test]
fn tui_help_scrollback_snippets_and_send_to_all() {
    if tmux_missing() {
        return;
    }
    let dir = std::env::temp_dir().join(format!("ursock-tui-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let snippets = dir.join("snippets.txt");
    std::fs::write(
        &snippets,
        "pose = floats 0.4 -0.2 0.3\nack = text OK\\r\\n\n",
    )
    .unwrap();
    let port = free_port();
    let t = start(
        "more",
        port,
        &format!(
            "--decode line --robot-reads ascii-float:2 --snippets {}",
            snippets.display()
        ),
    );
    // The help pane: every key, the commands, the snippets with their keys.
    t.key("F1");
    let pane = t.wait_for("help (Esc closes");
    for needle in [
        "PgUp / PgDn",
        "Alt+Enter",
        "F2 .. F9",
        "every SECONDS",
        "@* REPLY-SPEC",
    ] {
        assert!(pane.contains(needle), "{needle:?} not in the help:\n{pane}");
    }
    // Longer than the screen: PgDn scrolls the help itself.
    assert!(!pane.contains("Scrollback: the newest"), "{pane}");
    t.key("PageDown");
    let pane = t.wait_for("Scrollback: the newest 2000 lines");
    for needle in [
        "F2  $1   pose = floats 0.4 -0.2 0.3",
        "F3  $2   ack = text OK\\r\\n",
    ] {
        assert!(pane.contains(needle), "{needle:?} not in the help:\n{pane}");
    }
    t.key("Escape");
    t.wait_until("the help to close", |p| !p.contains("help (Esc closes"));
    // `?` opens it too while nothing is typed.
    t.keys("?");
    t.wait_for("help (Esc closes");
    t.key("Escape");
    t.wait_until("the help to close", |p| !p.contains("help (Esc closes"));

    // Scrollback: 80 lines, PgUp goes back, new lines do not move the view.
    let addr = format!("127.0.0.1:{port}");
    let mut a = robot(&addr);
    let lines: String = (0..80).map(|i| format!("msg {i:02}\n")).collect();
    a.write_all(lines.as_bytes()).unwrap();
    t.wait_for("= \"msg 79\"");
    t.key("PageUp");
    let back = t.wait_for("new lines below");
    assert!(!back.contains("= \"msg 79\""), "{back}");
    let before = new_below(&back);
    a.write_all(b"late\n").unwrap();
    let later = t.wait_until("the count of new lines to grow", |p| {
        p.contains("new lines below") && new_below(p) > before
    });
    assert!(!later.contains("= \"late\""), "the view moved:\n{later}");
    t.key("Home");
    t.wait_for("connected from 127.0.0.1:");
    t.key("End");
    let end = t.wait_for("= \"late\"");
    assert!(end.contains("(PgUp scrolls back)"), "{end}");
    // F12 captures the mouse: one notch of the wheel (an SGR wheel-up report, as a
    // terminal sends it) goes back 3 lines.
    t.key("F12");
    t.keys("\x1b[<64;60;10M");
    t.wait_for("scrolled back: 3 new lines below");
    t.key("F12");
    t.key("End");
    t.wait_for("(PgUp scrolls back)");

    // F2 sends the first snippet to the selected robot, `$ack` the second.
    t.key("F2");
    assert_eq!(read_n(&mut a, 14), b"(0.4,-0.2,0.3)");
    t.keys("$ack");
    t.key("Enter");
    assert_eq!(read_n(&mut a, 4), b"OK\r\n");

    // Alt+Enter sends the typed line to every robot; the status line names each one.
    let mut b = robot(&addr);
    b.write_all(b"second\n").unwrap();
    t.wait_for("#2 127.0.0.1:");
    t.keys("line ALL");
    t.key("M-Enter");
    assert_eq!(read_line(&mut a), "ALL\n");
    assert_eq!(read_line(&mut b), "ALL\n");
    t.wait_for("sent 4 bytes to 2 of 2 robots (#1 #2)");

    // A warning longer than the terminal is wrapped, not cut: its end is on screen (the
    // status area shows the newest general lines, wrapped, in up to 4 rows).
    t.keys("@1 line [0.1, 0.2]");
    t.key("Enter");
    let start = Instant::now();
    while !t
        .status()
        .contains("\",\".join(str(v) for v in values) + \")\"")
    {
        assert!(
            start.elapsed() < WAIT,
            "the warning's end is not shown:\n{}",
            t.status()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!(
        t.status().contains("a Python list, str(list), arrived"),
        "{}",
        t.status()
    );
    // A periodic send shows in the input's title until it is stopped.
    t.keys("every 0.2 @2 $ack");
    t.key("Enter");
    assert_eq!(read_n(&mut b, 4), b"OK\r\n");
    assert_eq!(read_n(&mut b, 4), b"OK\r\n");
    t.wait_for("| 1 periodic (every)");
    t.keys("every off");
    t.key("Enter");
    t.wait_until("the periodic send to stop", |p| {
        !p.contains("periodic (every)")
    });
    t.key("Escape");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn tui_shows_traffic_and_sends_typed_replies() {
    if tmux_missing() {
        return;
    }
    let port = free_port();
    let t = Tmux {
        socket: format!("ursock-test-{}", std::process::id()),
        session: "listen".into(),
    };
    let command = format!(
        "{} listen --tui --bind 127.0.0.1 --port {port} --decode line --robot-reads ascii-float:2",
        listen_common::bin()
    );
    let out = t.cmd(&[
        "new-session",
        "-d",
        "-s",
        &t.session,
        "-x",
        "150",
        "-y",
        "30",
        &command,
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    t.wait_for("robots (Up/Down)");
    let addr = format!("127.0.0.1:{port}");
    let mut a = robot(&addr);
    a.write_all("hello café\n".as_bytes()).unwrap();
    let pane = t.wait_for("= \"hello café\"");
    assert!(pane.contains("#1 127.0.0.1:"), "{pane}");
    assert!(pane.contains("#1 traffic"), "{pane}");
    t.keys("line OK");
    t.wait_for("> line OK");
    t.key("Enter");
    assert_eq!(read_line(&mut a), "OK\n");
    t.wait_for("-> 3");
    // A second robot; Down selects it and a hex reply goes to it alone.
    let mut b = robot(&addr);
    b.write_all(b"second\n").unwrap();
    t.wait_for("#2 127.0.0.1:");
    t.key("Down");
    t.wait_for("#2 traffic");
    t.keys("hex 02 41 03");
    t.key("Enter");
    let mut got = [0u8; 3];
    std::io::Read::read_exact(&mut b, &mut got).unwrap();
    assert_eq!(got, [2, 0x41, 3]);
    // A diagnosis shows in the status line.
    t.keys("line [0.1, 0.2]");
    t.key("Enter");
    t.wait_for("str(list)");
    t.key("Escape");
    let start = Instant::now();
    while t.cmd(&["has-session", "-t", &t.session]).status.success() {
        assert!(start.elapsed() < WAIT, "Esc did not quit:\n{}", t.capture());
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Issue 30: `listen --tui --robot FILE` shows the virtual robot's moves, a line when
/// each starts and ends, beside the traffic it sent.
#[test]
fn the_tui_shows_the_robots_moves() {
    if tmux_missing() {
        return;
    }
    let dir = std::env::temp_dir().join(format!("ursock-tui-robot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let program = dir.join("moves.script");
    std::fs::write(
        &program,
        "socket_send_line(\"hello\")\nmovej([0.5, -1.5, 1, -1, 0.2, 0], a=3, v=3)\nset_standard_digital_out(1, True)\nsleep(30)\n",
    )
    .unwrap();
    let t = start(
        "robot",
        free_port(),
        &format!("--decode line --robot {}", program.display()),
    );
    let pane = t.wait_for("reached in");
    assert!(
        pane.contains("line 2: movej -> [0.5, -1.5, 1, -1, 0.2, 0] starts (v 3, a 3)"),
        "{pane}"
    );
    let pane = t.wait_for("set_standard_digital_out(1, True)");
    assert!(
        pane.contains("= \"hello\""),
        "the traffic beside it:\n{pane}"
    );
    println!("{pane}");
    t.key("Escape");
    let _ = std::fs::remove_dir_all(&dir);
}
