//! The in-process server (`net::Server`), as a driver's own Rust tests would use it: start
//! a controller on free ports, drive it over TCP as a client, watch its events, act as
//! the operator, stop it.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

mod support;
use support::*;
use urscript_controller::net::{ServerEvent, ServerOptions};
use urscript_controller::SafetyStatus;

#[test]
fn a_test_starts_a_controller_drives_it_and_stops_it() {
    let (server, events) = start();
    let services: Vec<&str> = server.addrs().iter().map(|(s, _)| *s).collect();
    assert_eq!(
        services,
        [
            "dashboard",
            "primary",
            "secondary",
            "realtime",
            "rtde",
            "interpreter"
        ]
    );
    // The listening events came before start returned.
    let first: Vec<ServerEvent> = events.try_iter().take(6).collect();
    assert!(first
        .iter()
        .all(|e| matches!(e, ServerEvent::Listening { .. })));
    let mut d = LineClient::dashboard(&server);
    assert_eq!(d.say("brake release"), "Brake releasing");
    let start = Instant::now();
    while d.say("robotmode") != "Robotmode: RUNNING" {
        assert!(start.elapsed() < WAIT);
        std::thread::sleep(Duration::from_millis(20));
    }
    let mut primary = TcpStream::connect(server.addr("primary").unwrap()).unwrap();
    primary
        .write_all(b"def greet():\n  textmsg(\"hello from the arm\")\n  sleep(30)\nend\n")
        .unwrap();
    let message = wait_for(&events, |e| matches!(e, ServerEvent::Message(_)));
    match message {
        ServerEvent::Message(m) => assert_eq!(m.text, "hello from the arm"),
        _ => unreachable!(),
    }
    assert_eq!(d.say("programState"), "PLAYING <unnamed>");
    // The operator (or the cell around the robot) acts through the cell.
    server.with_cell(|cell, now| cell.controller().protective_stop(now));
    assert_eq!(d.say("safetystatus"), "Safetystatus: PROTECTIVE_STOP");
    // A program a client sent ends there (a loaded one would pause).
    assert_eq!(d.say("programState"), "STOPPED <unnamed>");
    let status = server.with_cell(|cell, _| cell.status());
    assert_eq!(status.safety, SafetyStatus::ProtectiveStop);
    // Stopping closes every listener.
    let primary_addr = server.addr("primary").unwrap();
    server.stop();
    assert!(
        TcpStream::connect_timeout(&primary_addr, Duration::from_secs(2)).is_err(),
        "still listening after stop"
    );
    let mut rest = Vec::new();
    let _ = primary.read_to_end(&mut rest); // the server side closed
}

#[test]
fn shutdown_on_the_dashboard_stops_the_server() {
    let (server, events) = start();
    let mut d = LineClient::dashboard(&server);
    assert_eq!(d.say("shutdown"), "Shutting down");
    wait_for(&events, |e| *e == ServerEvent::Shutdown);
    assert!(server.is_stopped());
}

#[test]
fn the_primary_interfaces_unlock_lets_the_next_program_run() {
    // UR's client library unlocks through the primary interface right after a stop and
    // then sends its next program: the unlock has to take effect when it arrives.
    let (server, events) = start();
    let mut d = LineClient::dashboard(&server);
    assert_eq!(d.say("brake release"), "Brake releasing");
    let start = Instant::now();
    while d.say("robotmode") != "Robotmode: RUNNING" {
        assert!(start.elapsed() < WAIT);
        std::thread::sleep(Duration::from_millis(20));
    }
    server.with_cell(|cell, now| cell.controller().protective_stop(now));
    assert_eq!(d.say("safetystatus"), "Safetystatus: PROTECTIVE_STOP");
    let mut primary = TcpStream::connect(server.addr("primary").unwrap()).unwrap();
    // One write: the command, then a program the stop would refuse.
    primary
        .write_all(
            b"set unlock protective stop\ndef after_unlock():\n  textmsg(\"moving again\")\nend\n",
        )
        .unwrap();
    let message = wait_for(&events, |e| matches!(e, ServerEvent::Message(_)));
    match message {
        ServerEvent::Message(m) => assert_eq!(m.text, "moving again"),
        _ => unreachable!(),
    }
    assert_eq!(d.say("safetystatus"), "Safetystatus: NORMAL");
    server.stop();
}

/// A `.urp` file as PolyScope saves it (gzip-compressed XML) with one script line:
/// `textmsg("TEXT")`, each character an `<ExpressionChar>`.
fn textmsg_urp(text: &str) -> Vec<u8> {
    let chars: String = format!("textmsg(\"{text}\")")
        .chars()
        .map(|c| match c {
            '"' => "<ExpressionChar character=\"&quot;\"/>".to_string(),
            c => format!("<ExpressionChar character=\"{c}\"/>"),
        })
        .collect();
    let xml = format!(
        r#"<URProgram name="hello" installation="default" directory="/ursim/programs" createdIn="5.21.0" lastSavedIn="5.21.0">
  <children>
    <MainProgram runOnlyOnce="true">
      <children>
        <Script type="Line"><expression>{chars}</expression></Script>
      </children>
    </MainProgram>
  </children>
</URProgram>"#
    );
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    std::io::Write::write_all(&mut gz, xml.as_bytes()).unwrap();
    gz.finish().unwrap()
}

/// `Profile::Ursim` answers as URSim does in UR's client library's CI: programs by
/// `/ursim/programs/NAME` (read from the programs directory when played),
/// `default.installation` always there, remote control off, URSim's serial number. A
/// robot (the default profile) knows none of that path.
#[test]
fn the_ursim_profile_answers_as_ursim() {
    use urscript_controller::net::{Profile, URSIM_SERIAL};
    let dir = std::env::temp_dir().join(format!("ursock-ursim-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("hello.urp"), textmsg_urp("hello from ursim")).unwrap();
    let serve = |profile: Profile| {
        start_with(ServerOptions {
            programs: Some(dir.clone()),
            profile,
            ..any_ports()
        })
    };

    let (server, events) = serve(Profile::Ursim);
    let mut d = LineClient::dashboard(&server);
    assert_eq!(d.say("is in remote control"), "false");
    assert_eq!(d.say("get serial number"), URSIM_SERIAL);
    assert_eq!(
        d.say("load installation default.installation"),
        "Loading installation: default.installation"
    );
    assert_eq!(
        d.say("load /ursim/programs/hello.urp"),
        "Loading program: /ursim/programs/hello.urp"
    );
    assert_eq!(
        d.say("get loaded program"),
        "Loaded program: /ursim/programs/hello.urp"
    );
    assert_eq!(
        d.say("load /ursim/programs/../hello.urp"),
        "File not found: /ursim/programs/../hello.urp"
    );
    assert_eq!(d.say("load hello.urp"), "Loading program: hello.urp");
    assert_eq!(
        d.say("get loaded program"),
        "Loaded program: /ursim/programs/hello.urp"
    );
    // Played, it is read from the programs directory.
    assert_eq!(d.say("brake release"), "Brake releasing");
    let start = Instant::now();
    while d.say("robotmode") != "Robotmode: RUNNING" {
        assert!(start.elapsed() < WAIT);
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(d.say("play"), "Starting program");
    match wait_for(&events, |e| matches!(e, ServerEvent::Message(_))) {
        ServerEvent::Message(m) => assert_eq!(m.text, "hello from ursim"),
        _ => unreachable!(),
    }
    server.stop();

    let (server, _events) = serve(Profile::Robot);
    let mut d = LineClient::dashboard(&server);
    assert_eq!(d.say("is in remote control"), "true");
    assert_ne!(d.say("get serial number"), URSIM_SERIAL);
    assert_eq!(
        d.say("load /ursim/programs/hello.urp"),
        "File not found: /ursim/programs/hello.urp"
    );
    assert_eq!(
        d.say("load installation default.installation"),
        "File not found: default.installation"
    );
    server.stop();
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_stop_before_the_loops_first_step_is_a_change_of_state() {
    // The operator acts before the loop stepped once (the loop is held in its first
    // event, `scheduling`, until the stop is made): the change from the state the
    // controller started in is still said.
    let (go_tx, go_rx) = std::sync::mpsc::channel::<()>();
    let go_rx = std::sync::Mutex::new(go_rx);
    let (tx, events) = std::sync::mpsc::channel();
    let tx = std::sync::Mutex::new(tx);
    let server = urscript_controller::net::Server::start(any_ports(), move |e| {
        if matches!(e, ServerEvent::Scheduling(_)) {
            let _ = go_rx.lock().unwrap().recv_timeout(WAIT);
        }
        let _ = tx.lock().unwrap().send(e);
    })
    .expect("the server starts");
    server.with_cell(|cell, now| cell.controller().protective_stop(now));
    go_tx.send(()).unwrap();
    let e = wait_for(&events, |e| matches!(e, ServerEvent::State { .. }));
    assert!(
        matches!(
            e,
            ServerEvent::State {
                safety: SafetyStatus::ProtectiveStop,
                ..
            }
        ),
        "{e:?}"
    );
    server.stop();
}

/// The dashboard's framing over TCP: a line of more than 4096 bytes (a `\r` before its
/// `\n` counted) is answered as soon as the bound is passed, with its first 40 bytes,
/// and dropped to its `\n`, however it arrives; one `\r` before the `\n` is dropped;
/// the event shows the first 40 characters.
#[test]
fn dashboard_lines_long_split_and_with_cr() {
    let (server, events) = start();
    let mut d = LineClient::dashboard(&server);
    let long = |n: usize| "é".repeat(n / 2);
    let too_long = format!(
        "could not understand: '{}...' (a command line is at most 4096 bytes)",
        "é".repeat(20)
    );
    // 4096 bytes of content and a CR: past the bound, answered before its LF.
    d.writer
        .write_all(format!("{}\r", long(4096)).as_bytes())
        .unwrap();
    assert_eq!(d.read_line(), too_long);
    let shown = format!("{}...", "é".repeat(40));
    wait_for(
        &events,
        |e| matches!(e, ServerEvent::Dashboard { command, .. } if *command == shown),
    );
    // The rest of it (in pieces) is dropped; the next line is answered.
    for piece in ["ééé", "é\r", "\nrobotmode\r", "\n"] {
        d.writer.write_all(piece.as_bytes()).unwrap();
        std::thread::sleep(Duration::from_millis(5));
    }
    assert_eq!(d.read_line(), "Robotmode: POWER_OFF");
    // 4094 bytes and a CR fit: an unknown command, echoed whole, without its CR.
    let fits = long(4094);
    assert_eq!(
        d.say(&format!("{fits}\r")),
        format!("could not understand: '{fits}'")
    );
    // Two CRs: one is dropped, the other is a blank the dashboard trims.
    assert_eq!(d.say("ROBOTMODE\r\r"), "Robotmode: POWER_OFF");
    drop(server);
}

/// Accepts one connection on `listener` and reads it to its end (hang guard: `WAIT`).
fn read_one_connection(listener: std::net::TcpListener) -> std::thread::JoinHandle<String> {
    std::thread::spawn(move || {
        listener.set_nonblocking(true).unwrap();
        let start = Instant::now();
        let mut s = loop {
            match listener.accept() {
                Ok((s, _)) => break s,
                Err(_) if start.elapsed() < WAIT => {
                    std::thread::sleep(Duration::from_millis(5));
                }
                Err(e) => panic!("the program never connected: {e}"),
            }
        };
        s.set_nonblocking(false).unwrap();
        s.set_read_timeout(Some(WAIT)).unwrap();
        let mut got = String::new();
        s.read_to_string(&mut got)
            .expect("read until the program closes");
        got
    })
}

#[test]
fn a_secondary_program_sends_on_a_socket_of_its_own() {
    let (server, rx) = start();
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let got = read_one_connection(listener);
    let mut secondary = TcpStream::connect(server.addr("secondary").unwrap()).unwrap();
    secondary
        .write_all(
            format!(
                "sec s():\n  socket_open(\"127.0.0.1\", {port}, \"x\")\n  socket_send_string(\"hi\", \"x\")\n  socket_close(\"x\")\n  textmsg(\"sent\")\nend\n"
            )
            .as_bytes(),
        )
        .unwrap();
    assert_eq!(got.join().unwrap(), "hi");
    wait_for(
        &rx,
        |e| matches!(e, ServerEvent::Message(m) if m.text == "sent"),
    );
    // Nothing was reported unfinished.
    server.stop();
    let refused: Vec<ServerEvent> = rx
        .try_iter()
        .filter(|e| format!("{e:?}").contains("unfinished"))
        .collect();
    assert!(refused.is_empty(), "{refused:?}");
}

#[test]
fn a_secondary_program_calls_xml_rpc() {
    let (server, rx) = start();
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    // One XML-RPC server call: read the request's headers and body, answer 3.
    let rpc = std::thread::spawn(move || {
        listener.set_nonblocking(true).unwrap();
        let start = Instant::now();
        let s = loop {
            match listener.accept() {
                Ok((s, _)) => break s,
                Err(_) if start.elapsed() < WAIT => std::thread::sleep(Duration::from_millis(5)),
                Err(e) => panic!("the program never called: {e}"),
            }
        };
        s.set_nonblocking(false).unwrap();
        s.set_read_timeout(Some(WAIT)).unwrap();
        let mut r = BufReader::new(s.try_clone().unwrap());
        let mut length = 0;
        loop {
            let mut line = String::new();
            r.read_line(&mut line).unwrap();
            if let Some(v) = line.to_ascii_lowercase().strip_prefix("content-length:") {
                length = v.trim().parse().unwrap();
            }
            if line.trim().is_empty() {
                break;
            }
        }
        let mut body = vec![0; length];
        r.read_exact(&mut body).unwrap();
        let reply = "<?xml version=\"1.0\"?><methodResponse><params><param><value><int>3</int></value></param></params></methodResponse>";
        let mut w = s;
        write!(
            w,
            "HTTP/1.1 200 OK\r\nContent-Type: text/xml\r\nContent-Length: {}\r\n\r\n{reply}",
            reply.len()
        )
        .unwrap();
        String::from_utf8(body).unwrap()
    });
    let mut secondary = TcpStream::connect(server.addr("secondary").unwrap()).unwrap();
    secondary
        .write_all(
            format!(
                "sec s():\n  h = rpc_factory(\"xmlrpc\", \"http://127.0.0.1:{port}/RPC2\")\n  textmsg(\"sum \", h.add(1, 2))\nend\n"
            )
            .as_bytes(),
        )
        .unwrap();
    let request = rpc.join().unwrap();
    assert!(
        request.contains("<methodName>add</methodName>"),
        "{request}"
    );
    wait_for(
        &rx,
        |e| matches!(e, ServerEvent::Message(m) if m.text == "sum 3"),
    );
    server.stop();
}

/// The real-time loop owns the cell while it runs: what a test (or the dashboard) asks of
/// the cell runs on the loop's thread, every request of many threads at once is answered
/// (more than the request queue holds), and once the loop has ended a request runs on
/// its caller's thread.
#[test]
fn the_loop_owns_the_cell_and_answers_every_request() {
    let (server, _events) = start();
    let on = server.with_cell(|_, _| std::thread::current().name().map(str::to_string));
    assert_eq!(on.as_deref(), Some("controller"));
    let server = std::sync::Arc::new(server);
    let askers: Vec<_> = (0..urscript_controller::net::MAX_REQUESTS + 44)
        .map(|k| {
            let server = std::sync::Arc::clone(&server);
            std::thread::spawn(move || server.with_cell(move |cell, _| (k, cell.step_time())))
        })
        .collect();
    for (k, t) in askers.into_iter().enumerate() {
        assert_eq!(t.join().unwrap(), (k, Duration::from_millis(2)));
    }
    // Shut down (as on SIGTERM): the loop parks the cell and a request runs here.
    server.shut_down();
    let here = std::thread::current().name().map(str::to_string);
    let on = server.with_cell(|_, _| std::thread::current().name().map(str::to_string));
    assert_eq!(on, here);
}

/// A request whose function panics fails its caller only: the loop goes on serving.
#[test]
fn a_request_that_panics_fails_its_caller_and_the_loop_goes_on() {
    let (server, _events) = start();
    let failed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        server.with_cell(|_, _| -> u8 { panic!("a bug in the caller's function") })
    }));
    assert!(failed.is_err());
    let mut d = LineClient::dashboard(&server);
    assert_eq!(d.say("robotmode"), "Robotmode: POWER_OFF");
    let on = server.with_cell(|_, _| std::thread::current().name().map(str::to_string));
    assert_eq!(on.as_deref(), Some("controller"));
}

/// A client's items keep their order though its program is compiled on a thread of its
/// own: `stop program` sent right after a program stops that program (it does not come
/// first and leave the program running).
#[test]
fn a_command_after_a_program_acts_after_that_program_started() {
    let (server, rx) = start();
    running(&server);
    let mut s = connect_to(&server, "primary");
    s.write_all(b"def first():\n  textmsg(\"first\")\n  sleep(30)\nend\nstop program\n")
        .expect("send");
    let mut seen = Vec::new();
    while seen.len() < 2 {
        if let ServerEvent::Program { what, name, .. } =
            wait_for(&rx, |e| matches!(e, ServerEvent::Program { .. }))
        {
            seen.push(format!("{what} {name}"));
        }
    }
    assert_eq!(seen, ["started first", "stopped first"]);
    // The program after it starts once it is compiled.
    s.write_all(b"def second():\n  sleep(30)\nend\n")
        .expect("send");
    let ServerEvent::Program { what, name, .. } =
        wait_for(&rx, |e| matches!(e, ServerEvent::Program { .. }))
    else {
        unreachable!()
    };
    assert_eq!((what, name.as_str()), ("started", "second"));
    server.stop();
}
