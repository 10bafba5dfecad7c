//! Issue 17: `ursock robot` prints what the interpreter's typed events say, never text it
//! parsed back: quotes inside strings, `socket_close`, JSON lines with an `event` key.

use std::process::{Command, Stdio};

fn robot(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_ursock"))
        .arg("robot")
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("spawn ursock");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn a_quote_inside_a_message_shifts_nothing() {
    let (code, out, err) = robot(&[
        "-e",
        "textmsg('a\"b')",
        "-e",
        "textmsg(\"second\")",
        "-e",
        "textmsg(\"third\")",
    ]);
    assert_eq!(code, 0, "{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(
        lines,
        [
            "textmsg('a\"b') -> a\"b",
            "textmsg(\"second\") -> second",
            "textmsg(\"third\") -> third"
        ]
    );
    // The same with --json and a stub whose value holds a quote.
    let (code, out, err) = robot(&[
        "--json",
        "--stub",
        "rq_name='q\"q'",
        "-e",
        "x = rq_name()",
        "-e",
        "textmsg(x)",
        "-e",
        "textmsg(\"last\")",
    ]);
    assert_eq!(code, 0, "{err}");
    let events: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    let texts: Vec<&str> = events
        .iter()
        .filter(|e| e["event"] == "message")
        .map(|e| e["text"].as_str().unwrap())
        .collect();
    assert_eq!(texts, ["q\"q", "last"]);
    let stub = events.iter().find(|e| e["call"] == "rq_name").unwrap();
    assert_eq!(stub["outcome"], "stubbed");
    assert_eq!(stub["result"]["text"], "q\"q");
}

#[test]
fn socket_close_is_shown_and_every_json_line_names_its_event() {
    let script = "socket_close()\nx = socket_read_line(timeout=0.01)\nsocket_send_line(\"a\")";
    let (code, out, err) = robot(&["-e", script]);
    assert_eq!(code, 0, "{err}");
    assert!(out.lines().any(|l| l == "socket_close()"), "{out}");
    assert!(
        err.contains("socket_read_line: the socket \"socket_0\" is not open"),
        "{err}"
    );
    let (code, out, err) = robot(&["--json", "-e", script]);
    assert_eq!(code, 0, "{err}");
    let events: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    assert!(events.iter().all(|e| e["event"].is_string()), "{out}");
    let calls: Vec<&str> = events
        .iter()
        .filter(|e| e["event"] == "call")
        .map(|e| e["call"].as_str().unwrap())
        .collect();
    assert_eq!(
        calls,
        ["socket_close", "socket_read_line", "socket_send_line"]
    );
    let send = &events[2];
    assert_eq!(send["outcome"], "failed");
    assert_eq!(send["result"], false);
    assert_eq!(send["column"], 1);
    assert_eq!(events.last().unwrap()["event"], "end");
    assert_eq!(events.last().unwrap()["outcome"], "finished");
}

#[test]
fn a_call_with_wrong_arguments_is_refused_before_anything_runs() {
    let (code, out, err) = robot(&[
        "-e",
        "textmsg(\"never\")",
        "-e",
        "x = socket_read_ascii_float(6, \"cam\", timeuot=1)",
    ]);
    assert_ne!(code, 0);
    assert!(out.is_empty(), "{out}");
    assert!(
        err.contains("line 2, column 5: `socket_read_ascii_float` has no parameter `timeuot`"),
        "{err}"
    );
}

#[test]
fn the_arm_model_sets_the_kinematics() {
    // All joints at 0: the flange lies at (a2 + a3, -(d4 + d6), d1 - d5) of the model.
    let (code, out, err) = robot(&[
        "--model",
        "ur10e",
        "-e",
        "textmsg(get_forward_kin([0, 0, 0, 0, 0, 0])[0])",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.ends_with("-> -1.18425\n"), "{out}");
    let (code, _, err) = robot(&["--model", "ur99", "-e", "textmsg(1)"]);
    assert_ne!(code, 0);
    assert!(err.contains("unknown model `ur99`"), "{err}");
}

/// Issue 30: a move is one line for people (where it went, how it ended, how long it
/// took), a servo stream one line with its sample count, an output change one line.
#[test]
fn moves_and_outputs_are_one_line_each() {
    let (code, out, err) = robot(&[
        "-e",
        "movej([0.5, -1.5, 1, -1, 0.2, 0], a=3, v=3)",
        "-e",
        "set_standard_digital_out(1, True)",
        "-e",
        "set_standard_digital_out(1, True)",
        "-e",
        "q = get_actual_joint_positions()",
        "-e",
        "i = 0",
        "-e",
        "while i < 20:\n q[0] = q[0] + 0.01\n servoj(q, t=0.004)\n i = i + 1\nend",
        "-e",
        "speedj([0.1, 0, 0, 0, 0, 0], 1, 0.1)",
        "-e",
        "stopj(2)",
    ]);
    assert_eq!(code, 0, "{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(
        lines,
        [
            "line 1: movej -> [0.5, -1.5, 1, -1, 0.2, 0]: reached in 1.156 s",
            "line 2: set_standard_digital_out(1, True)",
            "line 8: servoj x20: reached in 0.08 s at [0.7, -1.5, 1, -1, 0.2, 0]",
            "line 11: speedj -> speed [0.1, 0, 0, 0, 0, 0]: stopped in 0.1 s at [0.705, -1.5, 1, -1, 0.2, 0]",
        ],
        "{out}"
    );
}

/// Issue 30: `--fail-on` makes a halt or an error popup fail the run (exit 1) so a CI
/// step fails with the program; without it they exit 0.
#[test]
fn fail_on_makes_a_halt_or_an_error_popup_exit_1() {
    let popup = "popup(\"gripper lost the part\", \"Gripper\", error=True)";
    assert_eq!(robot(&["-e", popup]).0, 0);
    let (code, _, err) = robot(&["--fail-on", "error-popup", "-e", popup]);
    assert_eq!(code, 1);
    assert!(
        err.contains(
            "line 1: the program showed an error popup \"Gripper\": gripper lost the part"
        ),
        "{err}"
    );
    // A popup that is no error fails only with `popup`.
    let info = "popup(\"done\", \"Info\")";
    assert_eq!(robot(&["--fail-on", "error-popup", "-e", info]).0, 0);
    assert_eq!(robot(&["--fail-on", "popup", "-e", info]).0, 1);
    assert_eq!(robot(&["-e", "halt"]).0, 0);
    let (code, _, err) = robot(&["--fail-on", "halt,protective-stop", "-e", "halt"]);
    assert_eq!(code, 1);
    assert!(err.contains("the program halted"), "{err}");
    let (code, _, err) = robot(&["--fail-on", "hlt", "-e", "halt"]);
    assert_eq!(code, 1);
    assert!(err.contains("--fail-on \"hlt\""), "{err}");
    // A protective stop always fails.
    assert_eq!(robot(&["-e", "protective_stop()"]).0, 1);
}

/// Issue 30: a name that is not found is said without the controller's code (it stays
/// in --json's `code`), with the nearest name when it looks like a typo.
#[test]
fn an_unknown_name_is_said_plainly_with_the_nearest_name() {
    let (code, _, err) = robot(&["-e", "x = 1", "-e", "movjj([0, 0, 0, 0, 0, 0])"]);
    assert_eq!(code, 1);
    assert!(!err.contains("compile_error"), "{err}");
    assert!(err.contains("line 2: `movjj` is neither defined"), "{err}");
    assert!(err.contains("did you mean `movej`?"), "{err}");
    let (_, _, err) = robot(&["-e", "def pick():\n sleep(0.01)\nend\npikc()"]);
    assert!(err.contains("did you mean `pick`?"), "{err}");
    let (_, _, err) = robot(&["-e", "count = 1\ny = cuont + 1"]);
    assert!(err.contains("did you mean `count`?"), "{err}");
    let (_, out, _) = robot(&["--json", "-e", "movjj(1)"]);
    let first = out.lines().next().unwrap();
    assert!(
        first.contains("\"code\":\"compile_error_name_not_found\""),
        "{first}"
    );
    assert!(first.contains("\"text\":\"`movjj` is neither"), "{first}");
}

/// The JSON events of a run without their wall-clock `t`.
fn program_events(args: &[&str]) -> Vec<serde_json::Value> {
    let (code, out, err) = robot(args);
    assert_eq!(code, 0, "{err}");
    out.lines()
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
            v.as_object_mut().unwrap().remove("t");
            v
        })
        .collect()
}

/// Issue 30: a program with no peers runs in virtual time with the same results as in
/// real time: the same events at the same program times.
#[test]
fn virtual_time_gives_the_same_results_as_real_time() {
    let program = [
        "--json",
        "-e",
        "movej([0.5, -1.5, 1, -1, 0.2, 0], a=3, v=3, r=0.05)",
        "-e",
        "movej([0.6, -1.5, 1, -1, 0.2, 0], a=3, v=3)",
        "-e",
        "sleep(0.25)",
        "-e",
        "set_standard_digital_out(3, True)",
        "-e",
        "movel(p[0.3, -0.2, 0.4, 0, 3.14, 0], a=1.2, v=0.5)",
        "-e",
        "textmsg(\"at \", get_actual_joint_positions())",
    ];
    let real = program_events(&program);
    let mut virtual_args = vec!["--virtual-time"];
    virtual_args.extend(program);
    let virtual_run = program_events(&virtual_args);
    assert_eq!(real, virtual_run);
    assert!(real.iter().filter(|e| e["event"] == "move_end").count() == 3);
}

/// Issue 30: an hour of `sleep` ends at once in virtual time; `--max-time` counts program
/// time there.
#[test]
fn virtual_time_does_not_wait_in_real_time() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_ursock"))
        .args([
            "robot",
            "--virtual-time",
            "-e",
            "sleep(3600)",
            "-e",
            "textmsg(\"an hour later\")",
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    // A hang guard, not a speed measure: in real time this would take an hour.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(120);
    while child.try_wait().unwrap().is_none() {
        if std::time::Instant::now() > deadline {
            let _ = child.kill();
            panic!("--virtual-time still sleeping after 120 s");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success());
    assert_eq!(
        String::from_utf8_lossy(&out.stdout),
        "textmsg(\"an hour later\") -> an hour later\n"
    );
    let (code, _, err) = robot(&[
        "--virtual-time",
        "--max-time",
        "1000",
        "-e",
        "while True:\n sleep(1)\nend",
    ]);
    assert_eq!(code, 0);
    assert!(err.contains("--max-time 1000s reached"), "{err}");
}
