//! `ursock listen --tui` in a real terminal: tmux runs it, a robot connects over
//! loopback, keys are sent and the pane is captured. Skips (and says why) without tmux.

mod listen_common;

use std::io::Write;
use std::process::Command;
use std::time::{Duration, Instant};

use listen_common::{read_line, robot, WAIT};

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

#[test]
fn tui_shows_traffic_and_sends_typed_replies() {
    if Command::new("tmux").arg("-V").output().is_err() {
        println!("skipped: tmux is not installed (apt-get install tmux)");
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
    t.wait_for("Python str(list)");
    t.key("Escape");
    let start = Instant::now();
    while t.cmd(&["has-session", "-t", &t.session]).status.success() {
        assert!(start.elapsed() < WAIT, "Esc did not quit:\n{}", t.capture());
        std::thread::sleep(Duration::from_millis(50));
    }
}
