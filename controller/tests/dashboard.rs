//! The dashboard server and the controller's state machine in virtual time: every
//! command with its exact reply text, the timed transitions, hostile lines.

use std::time::Duration;

use urscript_controller::{
    Config, Controller, Dashboard, Model, ProgramList, RobotMode, SafetyStatus, Timing,
    LOCAL_CONTROL, MAX_LINE, UNLOCK_TOO_EARLY,
};

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// A controller with `pick.urp`, `sub/place.urp` and `default.installation`, and a
/// session on it; `ask` answers one line at a time.
struct Session {
    c: Controller,
    d: Dashboard,
}

impl Session {
    fn new(config: Config) -> Self {
        let programs = ProgramList::new([
            "pick.urp",
            "sub/place.urp",
            "default.installation",
            "notes.txt",
        ]);
        Session {
            c: Controller::new(config).with_programs(Box::new(programs)),
            d: Dashboard::new(),
        }
    }

    fn ask(&mut self, line: &str, now: Duration) -> String {
        let reply = self.d.handle_line(&mut self.c, line, now);
        assert_eq!(reply.lines.len(), 1, "{line:?} -> {reply:?}");
        assert!(!reply.close || line == "quit" || line == "shutdown");
        reply.lines[0].clone()
    }
}

#[test]
fn greeting() {
    let g = Dashboard::greeting();
    assert_eq!(g.lines, ["Connected: Universal Robots Dashboard Server"]);
    assert_eq!(
        g.to_bytes(),
        b"Connected: Universal Robots Dashboard Server\n"
    );
    assert!(!g.close);
}

#[test]
fn power_on_idle_brake_release_running() {
    let mut s = Session::new(Config::default());
    assert_eq!(s.ask("robotmode", ms(0)), "Robotmode: POWER_OFF");
    assert_eq!(s.ask("power on", ms(0)), "Powering on");
    assert_eq!(s.ask("robotmode", ms(0)), "Robotmode: BOOTING");
    assert_eq!(s.c.poll_timeout(), Some(ms(100)));
    assert_eq!(s.ask("robotmode", ms(99)), "Robotmode: BOOTING");
    assert_eq!(s.ask("robotmode", ms(100)), "Robotmode: POWER_ON");
    assert_eq!(s.ask("robotmode", ms(199)), "Robotmode: POWER_ON");
    assert_eq!(s.ask("robotmode", ms(200)), "Robotmode: IDLE");
    assert_eq!(s.c.poll_timeout(), None);
    // power on again: nothing changes
    assert_eq!(s.ask("power on", ms(700)), "Powering on");
    assert_eq!(s.ask("robotmode", ms(700)), "Robotmode: IDLE");
    assert_eq!(s.ask("brake release", ms(1000)), "Brake releasing");
    assert_eq!(s.ask("robotmode", ms(1199)), "Robotmode: IDLE");
    assert_eq!(s.ask("robotmode", ms(1200)), "Robotmode: RUNNING");
    assert_eq!(s.ask("power off", ms(2000)), "Powering off");
    assert_eq!(s.ask("robotmode", ms(2000)), "Robotmode: POWER_OFF");
}

#[test]
fn brake_release_from_power_off_powers_on() {
    let mut s = Session::new(Config::default());
    assert_eq!(s.ask("brake release", ms(0)), "Brake releasing");
    assert_eq!(s.ask("robotmode", ms(50)), "Robotmode: BOOTING");
    assert_eq!(s.ask("robotmode", ms(150)), "Robotmode: POWER_ON");
    assert_eq!(s.ask("robotmode", ms(300)), "Robotmode: IDLE");
    // RUNNING 0.4 s after a brake release from POWER_OFF: UR's client library's tests,
    // in UR's CI order, send a program 0.6 s after one and want it to run.
    assert_eq!(s.ask("robotmode", ms(399)), "Robotmode: IDLE");
    assert_eq!(s.ask("robotmode", ms(400)), "Robotmode: RUNNING");
    // power on and brake release at once: the same 0.4 s (UR's ROS 2 driver's tests
    // wanted RUNNING within 1 s)
    let mut s = Session::new(Config::default());
    s.ask("power on", ms(0));
    s.ask("brake release", ms(0));
    assert_eq!(s.ask("robotmode", ms(399)), "Robotmode: IDLE");
    assert_eq!(s.ask("robotmode", ms(400)), "Robotmode: RUNNING");
    // a long jump settles every step at once
    let mut s = Session::new(Config::default());
    s.ask("brake release", ms(0));
    assert_eq!(
        s.ask("robotmode", Duration::from_secs(60)),
        "Robotmode: RUNNING"
    );
}

fn running(s: &mut Session) -> Duration {
    s.ask("brake release", ms(0));
    assert_eq!(s.ask("robotmode", ms(2000)), "Robotmode: RUNNING");
    ms(2000)
}

#[test]
fn programs_load_play_pause_stop() {
    let mut s = Session::new(Config::default());
    assert_eq!(s.ask("get loaded program", ms(0)), "No program loaded");
    assert_eq!(s.ask("programState", ms(0)), "STOPPED <unnamed>");
    assert_eq!(s.ask("isProgramSaved", ms(0)), "false <unnamed>");
    assert_eq!(s.ask("play", ms(0)), "Failed to execute: play");
    assert_eq!(s.ask("stop", ms(0)), "Failed to execute: stop");
    assert_eq!(s.ask("pause", ms(0)), "Failed to execute: pause");
    assert_eq!(
        s.ask("load missing.urp", ms(0)),
        "File not found: missing.urp"
    );
    assert_eq!(
        s.ask("load notes.txt", ms(0)),
        "Error while loading program: notes.txt"
    );
    assert_eq!(
        s.ask("load default.installation", ms(0)),
        "Error while loading program: default.installation"
    );
    assert_eq!(
        s.ask("load installation pick.urp", ms(0)),
        "Failed to load installation: pick.urp"
    );
    assert_eq!(s.ask("load pick.urp", ms(0)), "Loading program: pick.urp");
    assert_eq!(
        s.ask("get loaded program", ms(0)),
        "Loaded program: /programs/pick.urp"
    );
    assert_eq!(s.ask("programState", ms(0)), "STOPPED pick.urp");
    assert_eq!(s.ask("isProgramSaved", ms(0)), "true pick.urp");
    // not RUNNING yet
    assert_eq!(s.ask("play", ms(0)), "Failed to execute: play");
    let t = running(&mut s);
    assert_eq!(s.ask("running", t), "Program running: false");
    assert_eq!(s.ask("pause", t), "Failed to execute: pause");
    assert_eq!(s.ask("stop", t), "Stopped");
    assert_eq!(s.ask("programState", t), "STOPPED pick.urp");
    assert_eq!(s.ask("play", t), "Starting program");
    assert_eq!(s.ask("running", t), "Program running: true");
    assert_eq!(s.ask("programState", t), "PLAYING pick.urp");
    assert_eq!(
        s.ask("load sub/place.urp", t),
        "Error while loading program: sub/place.urp"
    );
    assert_eq!(s.ask("pause", t), "Pausing program");
    assert_eq!(s.ask("programState", t), "PAUSED pick.urp");
    assert_eq!(s.ask("running", t), "Program running: false");
    assert_eq!(s.ask("play", t), "Starting program");
    assert_eq!(s.ask("stop", t), "Stopped");
    assert_eq!(s.ask("programState", t), "STOPPED pick.urp");
    assert_eq!(
        s.ask("load /programs/sub/place.urp", t),
        "Loading program: /programs/sub/place.urp"
    );
    assert_eq!(s.ask("programState", t), "STOPPED place.urp");
    assert_eq!(
        s.ask("get loaded program", t),
        "Loaded program: /programs/sub/place.urp"
    );
    // power off stops a playing program
    s.ask("play", t);
    assert_eq!(s.ask("power off", t), "Powering off");
    assert_eq!(s.ask("programState", t), "STOPPED place.urp");
}

#[test]
fn protective_stop_holds_five_seconds() {
    let mut s = Session::new(Config::default());
    s.ask("load pick.urp", ms(0));
    let t = running(&mut s);
    s.ask("play", t);
    s.c.protective_stop(t);
    assert_eq!(s.ask("safetystatus", t), "Safetystatus: PROTECTIVE_STOP");
    assert_eq!(s.ask("safetymode", t), "Safetymode: PROTECTIVE_STOP");
    assert_eq!(s.ask("programState", t), "PAUSED pick.urp");
    assert_eq!(s.ask("robotmode", t), "Robotmode: RUNNING");
    assert_eq!(s.ask("play", t), "Failed to execute: play");
    assert_eq!(
        s.ask("unlock protective stop", t + ms(4999)),
        UNLOCK_TOO_EARLY
    );
    assert_eq!(
        UNLOCK_TOO_EARLY,
        "Cannot unlock protective stop until 5s after occurrence. Always inspect cause of protective stop before unlocking"
    );
    assert_eq!(
        s.ask("safetystatus", t + ms(4999)),
        "Safetystatus: PROTECTIVE_STOP"
    );
    assert_eq!(
        s.ask("unlock protective stop", t + ms(5000)),
        "Protective stop releasing"
    );
    assert_eq!(s.ask("safetystatus", t + ms(5000)), "Safetystatus: NORMAL");
    assert_eq!(
        s.ask("close safety popup", t + ms(5000)),
        "closing safety popup"
    );
    assert_eq!(s.ask("play", t + ms(5000)), "Starting program");
}

#[test]
fn emergency_stop_fault_and_restart_safety() {
    let mut s = Session::new(Config::default());
    let t = running(&mut s);
    s.c.safety_event(t, SafetyStatus::RobotEmergencyStop);
    assert_eq!(
        s.ask("safetystatus", t),
        "Safetystatus: ROBOT_EMERGENCY_STOP"
    );
    assert_eq!(s.ask("robotmode", t), "Robotmode: POWER_OFF");
    assert_eq!(s.ask("power on", t), "Powering on");
    assert_eq!(s.ask("robotmode", t + ms(1000)), "Robotmode: POWER_OFF");
    s.c.release_stop(t);
    assert_eq!(s.ask("safetystatus", t), "Safetystatus: NORMAL");

    s.c.safety_event(t, SafetyStatus::AutomaticModeSafeguardStop);
    assert_eq!(
        s.ask("safetystatus", t),
        "Safetystatus: AUTOMATIC_MODE_SAFEGUARD_STOP"
    );
    assert_eq!(s.ask("safetymode", t), "Safetymode: SAFEGUARD_STOP");
    s.c.release_stop(t);

    s.c.safety_event(t, SafetyStatus::Fault);
    s.c.release_stop(t);
    assert_eq!(s.ask("safetystatus", t), "Safetystatus: FAULT");
    assert_eq!(s.ask("restart safety", t), "Restarting safety");
    assert_eq!(s.ask("robotmode", t), "Robotmode: BOOTING");
    assert_eq!(s.ask("robotmode", t + ms(500)), "Robotmode: POWER_OFF");
    assert_eq!(s.ask("safetystatus", t + ms(500)), "Safetystatus: NORMAL");
}

#[test]
fn operational_mode_remote_control_and_identity() {
    let mut s = Session::new(Config::default());
    let t = ms(0);
    assert_eq!(s.ask("get operational mode", t), "NONE");
    assert_eq!(
        s.ask("set operational mode automatic", t),
        "Operational mode 'automatic' is set"
    );
    assert_eq!(s.ask("get operational mode", t), "AUTOMATIC");
    assert_eq!(
        s.ask("set operational mode MANUAL", t),
        "Operational mode 'MANUAL' is set"
    );
    assert_eq!(s.ask("get operational mode", t), "MANUAL");
    assert_eq!(
        s.ask("set operational mode none", t),
        "Failed setting operational mode: none"
    );
    assert_eq!(
        s.ask("clear operational mode", t),
        "No longer controlling the operational mode. Current operational mode: 'NONE'."
    );
    assert_eq!(s.ask("get operational mode", t), "NONE");
    // AUTOMATIC: only playing, no loading
    s.ask("set operational mode automatic", t);
    assert_eq!(
        s.ask("load pick.urp", t),
        "Error while loading program: pick.urp"
    );
    assert_eq!(
        s.ask("load installation default.installation", t),
        "Failed to load installation: default.installation"
    );
    s.ask("set operational mode manual", t);
    assert_eq!(s.ask("load pick.urp", t), "Loading program: pick.urp");
    s.ask("clear operational mode", t);
    assert_eq!(s.ask("is in remote control", t), "true");
    assert_eq!(s.ask("get serial number", t), "20235500001");
    assert_eq!(s.ask("get robot model", t), "UR5");
    assert_eq!(
        s.ask("PolyscopeVersion", t),
        "URSoftware 5.23.0.0 (Jan 01 2025)"
    );
    assert_eq!(
        s.ask("polyscopeversion", t),
        "URSoftware 5.23.0.0 (Jan 01 2025)"
    );
    assert_eq!(s.ask("version", t), "5.23.0.0");

    let mut s = Session::new(Config {
        model: Model::Ur16e,
        polyscope: "5.12.0.1101319".into(),
        serial: "20201600042".into(),
        ..Config::default()
    });
    assert_eq!(s.ask("get robot model", t), "UR16");
    assert_eq!(s.ask("get serial number", t), "20201600042");
    assert_eq!(s.ask("version", t), "5.12.0.1101319");
}

#[test]
fn local_control_refuses_actions_answers_queries() {
    let mut s = Session::new(Config {
        remote_control: false,
        ..Config::default()
    });
    let t = ms(0);
    for cmd in [
        "load pick.urp",
        "play",
        "stop",
        "pause",
        "power on",
        "power off",
        "brake release",
        "unlock protective stop",
        "restart safety",
        "load installation default.installation",
        "set operational mode manual",
        "clear operational mode",
        "shutdown",
    ] {
        assert_eq!(s.ask(cmd, t), LOCAL_CONTROL, "{cmd}");
    }
    assert_eq!(s.ask("is in remote control", t), "false");
    assert_eq!(s.ask("robotmode", t), "Robotmode: POWER_OFF");
    assert!(!s.c.is_shut_down());
    s.c.set_remote_control(true);
    assert_eq!(s.ask("power on", t), "Powering on");
}

#[test]
fn with_remote_control_disabled_commands_act_and_remote_control_is_false() {
    // The setting off (a new robot, URSim): no local/remote switch to refuse anything.
    let mut s = Session::new(Config {
        remote_control: false,
        remote_control_enabled: false,
        ..Config::default()
    });
    let t = ms(0);
    assert_eq!(s.ask("is in remote control", t), "false");
    assert_eq!(s.ask("load pick.urp", t), "Loading program: pick.urp");
    assert_eq!(
        s.ask("set operational mode automatic", t),
        "Operational mode 'automatic' is set"
    );
    assert_eq!(
        s.ask("clear operational mode", t),
        "No longer controlling the operational mode. Current operational mode: 'NONE'."
    );
    assert_eq!(s.ask("power on", t), "Powering on");
    // The switch means nothing while the setting is off.
    s.c.set_remote_control(true);
    assert_eq!(s.ask("is in remote control", t), "false");
    assert_eq!(s.ask("power off", t), "Powering off");
}

#[test]
fn every_command_is_answered() {
    let mut s = Session::new(Config::default());
    let t = ms(0);
    let table: &[(&str, &str)] = &[
        ("popup Hello there", "showing popup"),
        ("close popup", "closing popup"),
        ("addToLog a message", "Added log message"),
        ("addToLog", "No log message to add"),
        (
            "load installation default.installation",
            "Loading installation: default.installation",
        ),
        (
            "load installation nope.installation",
            "File not found: nope.installation",
        ),
        ("close safety popup", "closing safety popup"),
        ("safetystatus", "Safetystatus: NORMAL"),
        ("safetymode", "Safetymode: NORMAL"),
        ("unlock protective stop", "Protective stop releasing"),
        (
            "generate flight report controller",
            "Flight Report generated with id: 00000001",
        ),
        (
            "generate flight report",
            "Flight Report generated with id: 00000002",
        ),
        (
            "generate flight report bogus",
            "Error: report type 'bogus' is not one of controller, software, system",
        ),
        (
            "generate support file .",
            "Completed successfully: ur_20235500001_support_file_0003.zip",
        ),
        (
            "generate support file reports/",
            "Completed successfully: reports/ur_20235500001_support_file_0004.zip",
        ),
        ("saveLog", "Log saved to disk"),
        (
            "setUserRole programmer",
            "could not understand: 'setUserRole programmer'",
        ),
        ("getUserRole", "could not understand: 'getUserRole'"),
        ("hello", "could not understand: 'hello'"),
        ("", "could not understand: ''"),
        ("play now", "could not understand: 'play now'"),
        ("ROBOTMODE\r", "Robotmode: POWER_OFF"),
        ("  running  ", "Program running: false"),
    ];
    for (line, want) in table {
        assert_eq!(&s.ask(line, t), want, "{line:?}");
    }
    assert_eq!(s.c.popup(), None);
    assert_eq!(s.c.log().collect::<Vec<_>>(), ["a message"]);
    assert_eq!(s.c.installation(), "default.installation");

    let quit = s.d.handle_line(&mut s.c, "quit", t);
    assert_eq!(quit.lines, ["Disconnected"]);
    assert!(quit.close);
    let down = s.d.handle_line(&mut s.c, "shutdown", t);
    assert_eq!(down.lines, ["Shutting down"]);
    assert!(down.close);
    assert!(s.c.is_shut_down());
    assert_eq!(s.c.robot_mode(t), RobotMode::PowerOff);
}

#[test]
fn cb3_user_roles() {
    let mut s = Session::new(Config {
        model: Model::Ur5,
        polyscope: "3.15.0".into(),
        ..Config::default()
    });
    let t = ms(0);
    assert_eq!(
        s.ask("setUserRole operator", t),
        "Setting user role: operator"
    );
    assert_eq!(
        s.ask("setUserRole king", t),
        "Failed setting user role: king"
    );
    assert_eq!(s.ask("getUserRole", t), "PROGRAMMER");
    assert_eq!(s.ask("get robot model", t), "UR5");
}

#[test]
fn hostile_lines_never_panic() {
    let mut s = Session::new(Config::default());
    let t = ms(0);
    let huge = "x".repeat(MAX_LINE + 1);
    let r = s.ask(&huge, t);
    assert!(r.starts_with("could not understand: 'xxxx"), "{r}");
    assert!(r.len() < 200);
    let multibyte = "é".repeat(MAX_LINE);
    let r = s.ask(&multibyte, t);
    assert!(r.contains("at most 4096 bytes"), "{r}");
    let r = s.d.line_too_long("ééé");
    assert_eq!(r.lines.len(), 1);
    for line in [
        "\u{0}",
        "load",
        "load ",
        "load ../../etc/passwd",
        "popup",
        "set operational mode",
        "generate support file",
        "é",
        "power",
        "power onn",
        "\t\t",
        "load installation",
    ] {
        let r = s.d.handle_line(&mut s.c, line, t);
        assert_eq!(r.lines.len(), 1, "{line:?}");
        assert!(!r.close);
    }
    // time going backwards is harmless
    s.ask("power on", Duration::from_secs(10));
    s.ask("robotmode", Duration::from_secs(1));
    s.c.protective_stop(Duration::from_secs(10));
    assert_eq!(
        s.ask("unlock protective stop", Duration::from_secs(2)),
        UNLOCK_TOO_EARLY
    );
}

#[test]
fn timing_is_configurable() {
    let mut s = Session::new(Config {
        timing: Timing {
            booting: Duration::ZERO,
            power_on: Duration::ZERO,
            brake_release: Duration::ZERO,
            protective_stop_hold: Duration::from_secs(5),
            restart_safety: Duration::ZERO,
        },
        ..Config::default()
    });
    assert_eq!(s.ask("brake release", ms(0)), "Brake releasing");
    assert_eq!(s.ask("robotmode", ms(0)), "Robotmode: RUNNING");
}
