//! The real-time driver against servers on 127.0.0.1.
use std::io::{Read, Write};
use std::net::TcpListener;
use std::time::Duration;

use urscript_interp::drive::{run_tcp, Activity, Options, Outcome};
use urscript_interp::{Config, Event, Machine, Program};

fn int32s(v: &[i32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_be_bytes()).collect()
}

#[test]
fn external_control_like_program_against_a_tcp_reverse_server() {
    // Three servers, as a driver opens them; the reverse one streams 10 servoj messages
    // at about 500 Hz then MODE_STOPPED, as the crate's external_control example does.
    let reverse = TcpListener::bind("127.0.0.1:0").unwrap();
    let trajectory = TcpListener::bind("127.0.0.1:0").unwrap();
    let command = TcpListener::bind("127.0.0.1:0").unwrap();
    let ports = [&reverse, &trajectory, &command].map(|l| l.local_addr().unwrap().port());
    let rev = std::thread::spawn(move || {
        let (mut s, _) = reverse.accept().unwrap();
        for i in 0..10 {
            let t = f64::from(i) * 0.01;
            // Next-read timeout 1000 ms: a loaded test machine may stall for a while.
            let mut m = vec![1000];
            m.extend([t, -1.57 + t, 1.57, -1.57, -1.57, 0.0].map(|x| (x * 1e6).round() as i32));
            m.push(1);
            s.write_all(&int32s(&m)).unwrap();
            std::thread::sleep(Duration::from_millis(2));
        }
        s.write_all(&int32s(&[0, 0, 0, 0, 0, 0, 0, -2])).unwrap();
        let mut rest = Vec::new();
        let _ = s.read_to_end(&mut rest);
    });
    let traj = std::thread::spawn(move || {
        let (mut s, _) = trajectory.accept().unwrap();
        let mut got = Vec::new();
        s.read_to_end(&mut got).unwrap();
        got
    });
    let cmd = std::thread::spawn(move || {
        let (mut s, _) = command.accept().unwrap();
        let mut got = Vec::new();
        let _ = s.read_to_end(&mut got);
    });
    let src = std::fs::read_to_string(format!(
        "{}/tests/programs/external_control_like.script",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
    .replace("50001", &ports[0].to_string())
    .replace("50003", &ports[1].to_string())
    .replace("50004", &ports[2].to_string());
    let mut machine = Machine::new(Program::parse(&src).unwrap(), Config::default());
    let mut messages = Vec::new();
    let options = Options {
        max_time: Some(Duration::from_secs(10)),
        ..Options::default()
    };
    let mut received = 0;
    let outcome = run_tcp(&mut machine, &options, |a| match a {
        Activity::Event(Event::Message(m)) => messages.push(m.text.clone()),
        Activity::Received {
            socket_name: "reverse_socket",
            bytes,
        } => received += bytes.len(),
        _ => {}
    })
    .unwrap();
    assert_eq!(outcome, Outcome::Finished);
    assert_eq!(received, 11 * 32);
    rev.join().unwrap();
    assert_eq!(traj.join().unwrap(), int32s(&[0]));
    cmd.join().unwrap();
    // In real time two messages can land in one 2 ms step; the servo thread then takes
    // the newer target, as on a robot.
    let last = messages.last().cloned().unwrap_or_default();
    let n: i32 = last
        .strip_prefix("servo steps: ")
        .and_then(|n| n.parse().ok())
        .unwrap_or(0);
    // (0 only if a stalled test machine delivered everything in one step.)
    assert!(
        (0..=10).contains(&n) && last.starts_with("servo steps: "),
        "{messages:?}"
    );
    if n == 0 {
        return;
    }
    // It ends on one of the messages' joints: the last one, unless the stop message came
    // in the same step and the servo thread ended before servoing it.
    let q = machine.joint_positions();
    let k = (q[0] / 0.01).round();
    assert!(
        (0.0..=9.0).contains(&k) && (q[0] - k * 0.01).abs() < 1e-9,
        "{q:?}"
    );
    assert!((q[1] - (-1.57 + q[0])).abs() < 1e-9, "{q:?}");
}

#[test]
fn a_protective_stop_ends_the_run_where_the_arm_stopped() {
    // A movel far beyond the reach (the tool sets off, the path leaves the reach at
    // once from the upright start): a controller pauses the program at the stop, so the
    // statement after the move never runs, and the driver does not wait out the move.
    for src in [
        "textmsg(\"before\")\nmovel(p[1.5, 0, 0.3, 0, 3.14, 0], a=0.5, v=0.2)\ntextmsg(\"after\")\n",
        "textmsg(\"before\")\nprotective_stop()\ntextmsg(\"after\")\n",
    ] {
        let p = Program::parse(src).unwrap();
        let options = Options {
            max_time: Some(Duration::from_secs(20)),
            ..Options::default()
        };
        let t = std::time::Instant::now();
        let mut texts = Vec::new();
        let outcome = run_tcp(&mut Machine::new(p, Config::default()), &options, |a| {
            if let Activity::Event(Event::Message(m)) = a {
                texts.push(m.text.clone());
            }
        })
        .unwrap();
        assert_eq!(outcome, Outcome::ProtectiveStop, "{src}");
        assert_eq!(texts, ["before"], "{src}");
        assert!(t.elapsed() < Duration::from_secs(5), "{:?}", t.elapsed());
    }
}

#[test]
fn max_time_ends_a_program_that_loops_forever() {
    let p = Program::parse("while True:\n  sync()\nend\n").unwrap();
    let t = std::time::Instant::now();
    let options = Options {
        max_time: Some(Duration::from_millis(100)),
        ..Options::default()
    };
    let outcome = run_tcp(&mut Machine::new(p, Config::default()), &options, |_| {}).unwrap();
    assert_eq!(outcome, Outcome::MaxTime);
    assert!(t.elapsed() >= Duration::from_millis(100) && t.elapsed() < Duration::from_secs(2));
}

#[test]
fn runtime_error_and_refused_connection() {
    // A port nothing listens on: bind, take the port, drop the listener.
    let port = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let src = format!("ok = socket_open(\"127.0.0.1\", {port}, \"x\")\ntextmsg(ok)\ny = [1][3]\n");
    let mut msgs = Vec::new();
    let err = run_tcp(
        &mut Machine::new(Program::parse(&src).unwrap(), Config::default()),
        &Options::default(),
        |a| {
            if let Activity::Event(Event::Message(m)) = a {
                msgs.push(m.text.clone());
            }
        },
    )
    .unwrap_err();
    assert_eq!(msgs, ["False"]);
    assert_eq!(
        err.to_string(),
        "line 3: index out of range: index 3, length 1"
    );
}
