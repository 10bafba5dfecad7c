//! Shared helper of the offline tests (`cli.rs`, `debugging.rs`): the built binary, run
//! once with given stdin.
#![allow(dead_code)]

use std::io::Write;
use std::process::{Command, Stdio};

pub fn ursock() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ursock"))
}

/// Runs `ursock args` with `stdin` (written from a thread, so a command that stops
/// reading early cannot block the test); returns (exit code, stdout, stderr).
pub fn run(args: &[&str], stdin: &[u8]) -> (i32, String, String) {
    let mut child = ursock()
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn ursock");
    let mut input = child.stdin.take().unwrap();
    let data = stdin.to_vec();
    let writer = std::thread::spawn(move || {
        let _ = input.write_all(&data);
    });
    let out = child.wait_with_output().unwrap();
    let _ = writer.join();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}
