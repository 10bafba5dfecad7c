//! `rpc_factory("xmlrpc", url)` and `handle.name(args...)`: XML-RPC calls through the
//! machine's socket events, against an in-memory server in virtual time, a tiny XML-RPC
//! server on 127.0.0.1 through the real-time driver, and Python's `xmlrpc.server` when
//! python3 is installed.
mod common;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::time::Duration;

use common::{Harness, Input};
use urscript_interp::drive::{run_tcp, Options, Outcome};
use urscript_interp::{Config, Event, Machine, Program, RuntimeErrorKind, State, Value};

const URL: &str = "http://192.168.1.10:8000/RPC2";
const SOCKET: &str = "rpc:http://192.168.1.10:8000/RPC2";

/// An HTTP reply carrying `xml`.
fn http(xml: &str) -> Vec<u8> {
    format!(
        "HTTP/1.0 200 OK\r\nContent-Type: text/xml\r\nContent-Length: {}\r\n\r\n{xml}",
        xml.len()
    )
    .into_bytes()
}

fn response(value: &str) -> Vec<u8> {
    http(&format!(
        "<?xml version='1.0'?>\n<methodResponse>\n<params>\n<param>\n<value>{value}</value>\n</param>\n</params>\n</methodResponse>\n"
    ))
}

fn fault(code: i32, text: &str) -> Vec<u8> {
    http(&format!("<?xml version='1.0'?>\n<methodResponse><fault><value><struct><member><name>faultCode</name><value><int>{code}</int></value></member><member><name>faultString</name><value><string>{text}</string></value></member></struct></value></fault></methodResponse>"))
}

const POSE: &str = "<struct><member><name>x</name><value><double>0.4</double></value></member><member><name>y</name><value><double>-0.2</double></value></member><member><name>z</name><value><double>0.3</double></value></member><member><name>rx</name><value><double>0</double></value></member><member><name>ry</name><value><double>3.1</double></value></member><member><name>rz</name><value><double>0</double></value></member></struct>";

/// The body of a request (after the headers), checked to be one complete HTTP POST.
fn body_of(request: &[u8]) -> String {
    let text = String::from_utf8(request.to_vec()).unwrap();
    let (head, body) = text.split_once("\r\n\r\n").expect("headers end");
    assert!(head.starts_with("POST /RPC2 HTTP/1.1\r\n"), "{head}");
    assert!(head.contains("\r\nContent-Type: text/xml"), "{head}");
    assert!(
        head.contains(&format!("\r\nContent-Length: {}", body.len())),
        "{head}"
    );
    body.to_string()
}

/// An in-memory server: answers each request with `answer(body)` once `delay` of
/// virtual time has passed since it came.
fn serve(h: &mut Harness, delay: Duration, mut answer: impl FnMut(&str) -> Vec<u8>) -> State {
    let mut due: Option<(Duration, String, Vec<u8>)> = None;
    let mut now = Duration::ZERO;
    h.run(Duration::from_secs(30), |input| match input {
        Input::Received(name, bytes) => {
            let reply = answer(&body_of(bytes));
            due = Some((now + delay, name.to_string(), reply));
            Vec::new()
        }
        Input::Tick(t) => {
            now = t;
            match due.take() {
                Some((at, name, reply)) if at <= t => vec![(name, reply)],
                other => {
                    due = other;
                    Vec::new()
                }
            }
        }
        Input::Connected(..) => Vec::new(),
    })
    .clone()
}

#[test]
fn a_call_returns_a_pose_and_waits_for_the_reply() {
    // A thread counts steps while the call waits: the call consumes program time.
    let src = format!(
        "steps = 0\nthread count():\n  while True:\n    steps = steps + 1\n    sync()\n  end\nend\nrun count()\nrpc = rpc_factory(\"xmlrpc\", \"{URL}\")\npos = rpc.get_position(1, \"x\")\nwaited = steps\ntextmsg(pos)\n"
    );
    let mut h = Harness::new(&src, Config::default());
    let state = serve(&mut h, Duration::from_millis(100), |body| {
        assert!(
            body.contains("<methodName>get_position</methodName>"),
            "{body}"
        );
        assert!(
            body.contains("<params><param><value><int>1</int></value></param><param><value><string>x</string></value></param></params>"),
            "{body}"
        );
        response(POSE)
    });
    assert_eq!(state, State::Finished);
    assert_eq!(h.messages, ["p[0.4, -0.2, 0.3, 0, 3.1, 0]"]);
    assert_eq!(
        h.connects,
        [(SOCKET.to_string(), "192.168.1.10".to_string(), 8000)]
    );
    assert_eq!(h.closed, [SOCKET]);
    // 100 ms at 2 ms a step: the counting thread ran about 50 times while the call waited.
    let Some(Value::Int(waited)) = h.m.global("waited") else {
        panic!()
    };
    assert!((45..=55).contains(waited), "{waited}");
    // The call is recorded under its internal socket name.
    assert!(
        h.calls.iter().any(|c| c.starts_with(&format!(
            "10: rpc_factory(\"xmlrpc\", \"{URL}\").get_position(1, \"x\") -> p[0.4, -0.2"
        ))),
        "{:?}",
        h.calls
    );
}

#[test]
fn arguments_and_results_of_every_type() {
    let src = format!(
        "rpc = rpc_factory(\"xmlrpc\", \"{URL}\")\nr = rpc.echo(struct(a=1, b=[True, 2.5], s=\"<&>\"), p[0.1, 0, 0, 0, 0, 0])\nok = rpc.flag()\nn = rpc.nothing()\ntextmsg(r.a, r.b)\ntextmsg(r.s)\n"
    );
    let mut h = Harness::new(&src, Config::default());
    let mut bodies = Vec::new();
    let state = serve(&mut h, Duration::ZERO, |body| {
        bodies.push(body.to_string());
        if body.contains("<methodName>echo</methodName>") {
            // The struct comes back as the server sent it (the first parameter).
            let start = body.find("<param><value>").unwrap() + "<param><value>".len();
            let end = body.find("</value></param>").unwrap();
            response(&body[start..end])
        } else if body.contains("flag") {
            response("<boolean>0</boolean>")
        } else {
            http("<methodResponse><params></params></methodResponse>")
        }
    });
    assert_eq!(state, State::Finished, "{:?}", h.messages);
    assert_eq!(h.messages, ["1[True, 2.5]", "<&>"]);
    assert_eq!(h.m.global("ok"), Some(&Value::Bool(false)));
    assert_eq!(h.m.global("n"), Some(&Value::None));
    // The pose went as a struct of x, y, z, rx, ry, rz; the string escaped.
    assert!(
        bodies[0].contains("<member><name>x</name><value><double>0.1</double></value></member>")
    );
    assert!(bodies[0].contains("<string>&lt;&amp;&gt;</string>"));
    // Three calls, three connections, each closed.
    assert_eq!(h.connects.len(), 3);
    assert_eq!(h.closed.len(), 3);
}

#[test]
fn method_names_with_dots_call_the_dotted_method() {
    // As a URCap preamble writes it: `h.server.getTCP(id)` is the XML-RPC method
    // `server.getTCP`; a handle kept in a struct is reached through its member first.
    let src = format!(
        "h = rpc_factory(\"xmlrpc\", \"{URL}\")\nt = h.server.getTCP(\"uuid\")\ns = struct(cam=h)\nn = s.cam.system.listMethods()\ntextmsg(t, n)\n"
    );
    let mut h = Harness::new(&src, Config::default());
    let mut names = Vec::new();
    let state = serve(&mut h, Duration::ZERO, |body| {
        let start = body.find("<methodName>").unwrap() + "<methodName>".len();
        let end = body.find("</methodName>").unwrap();
        names.push(body[start..end].to_string());
        response("<int>7</int>")
    });
    assert_eq!(state, State::Finished, "{:?}", h.messages);
    assert_eq!(names, ["server.getTCP", "system.listMethods"]);
    assert_eq!(h.messages, ["77"]);
    // A struct member that is not there is still an error at the call.
    let (_, e) = failed("s = struct(a=1)\ns.b.get()\n", None);
    assert!(e.message().contains("no member `b`"), "{e}");
}

fn failed(src: &str, answer: Option<Vec<u8>>) -> (Harness, urscript_interp::RuntimeError) {
    let mut h = Harness::new(src, Config::default());
    let state = match answer {
        Some(a) => serve(&mut h, Duration::ZERO, move |_| a.clone()),
        None => h.run_silent(Duration::from_secs(30)).clone(),
    };
    let State::Error(e) = state else {
        panic!("{src}: no error: {state:?}")
    };
    (h, e)
}

#[test]
fn a_fault_is_a_runtime_error_at_the_call() {
    let src = format!("rpc = rpc_factory(\"xmlrpc\", \"{URL}\")\nx = 1\ny = rpc.missing(x)\n");
    let (h, e) = failed(&src, Some(fault(1, "method \"missing\" is not supported")));
    assert_eq!(e.kind(), RuntimeErrorKind::RemoteCall);
    assert_eq!((e.line(), e.column()), (3, 9));
    assert_eq!(
        e.message(),
        format!("XML-RPC call `missing` to {URL}: the server answered with fault 1: method \"missing\" is not supported")
    );
    assert_eq!(h.closed, [SOCKET]);
}

#[test]
fn no_answer_is_an_error_after_the_timeout() {
    let src = format!("rpc = rpc_factory(\"xmlrpc\", \"{URL}\")\nrpc.wait_forever()\n");
    let mut h = Harness::new(&src, Config::default());
    h.run_silent(Duration::from_millis(9_990));
    assert_eq!(h.m.state(), &State::Running);
    h.run_silent(Duration::from_secs(11));
    let State::Error(e) = h.m.state() else {
        panic!("{:?}", h.m.state())
    };
    assert_eq!(e.kind(), RuntimeErrorKind::RemoteCall);
    assert!(
        e.message().ends_with("no complete reply within 10 s"),
        "{e}"
    );
    assert_eq!(h.closed, [SOCKET]);
    // A connection reported after the call ended opens nothing.
    h.m.handle_connected(SOCKET, Ok(()));
    assert!(h.m.open_sockets().is_empty());
}

#[test]
fn a_refused_connection_is_an_error() {
    let src = format!("rpc = rpc_factory(\"xmlrpc\", \"{URL}\")\nrpc.f()\n");
    let mut h = Harness::new(&src, Config::default());
    h.refuse.push(8000);
    h.run_silent(Duration::from_secs(1));
    let State::Error(e) = h.m.state() else {
        panic!("{:?}", h.m.state())
    };
    assert_eq!(e.kind(), RuntimeErrorKind::RemoteCall);
    assert!(e.message().ends_with("could not connect: refused"), "{e}");
}

#[test]
fn malformed_and_hostile_replies_are_errors() {
    let src = format!("rpc = rpc_factory(\"xmlrpc\", \"{URL}\")\nrpc.f()\n");
    let cases: Vec<(Vec<u8>, &str)> = vec![
        (
            b"HTTP/1.1 500 Internal Server Error\r\nContent-Length: 0\r\n\r\n".to_vec(),
            "HTTP status \"HTTP/1.1 500 Internal Server Error\"",
        ),
        (response("<int>1.5</int>"), "is not a 32-bit int"),
        (
            response("<dateTime.iso8601>20260101T00:00:00</dateTime.iso8601>"),
            "<dateTime.iso8601> is not supported",
        ),
        (
            http("<methodResponse><params><param>"),
            "malformed XML-RPC reply",
        ),
        (
            response(&"<array><data><value>".repeat(100)),
            "nested more than 32 levels",
        ),
        (
            format!("HTTP/1.1 200 OK\r\nContent-Length: {}\r\n\r\n", 2 << 20).into_bytes(),
            "over 1048576",
        ),
    ];
    for (reply, want) in cases {
        let (_, e) = failed(&src, Some(reply));
        assert_eq!(e.kind(), RuntimeErrorKind::RemoteCall, "{want}");
        assert!(e.message().contains(want), "{want}: {e}");
    }
    // A reply that never ends its body grows to the bound and stops there.
    let mut h = Harness::new(&src, Config::default());
    h.run(Duration::from_secs(5), |input| match input {
        Input::Received(name, _) => {
            let mut r = b"HTTP/1.1 200 OK\r\n\r\n".to_vec();
            r.extend(std::iter::repeat_n(b' ', 600_000));
            vec![(name.to_string(), r.clone()), (name.to_string(), r)]
        }
        _ => Vec::new(),
    });
    let State::Error(e) = h.m.state() else {
        panic!("{:?}", h.m.state())
    };
    assert!(
        e.message()
            .ends_with("the reply is longer than 1048576 bytes"),
        "{e}"
    );
}

#[test]
fn the_peer_closing_ends_the_reply() {
    let src = format!("rpc = rpc_factory(\"xmlrpc\", \"{URL}\")\nx = rpc.f()\ny = rpc.f()\n");
    let mut m = Machine::new(Program::parse(&src).unwrap(), Config::default());
    let mut now = Duration::ZERO;
    let mut step = |m: &mut Machine| {
        m.run_until(now);
        now += Duration::from_millis(2);
        std::iter::from_fn(|| m.poll_event()).collect::<Vec<_>>()
    };
    // First call: a reply without Content-Length ends when the server closes.
    let events = step(&mut m);
    assert!(events
        .iter()
        .any(|e| matches!(e, Event::Connect { socket_name, .. } if socket_name == SOCKET)));
    m.handle_connected(SOCKET, Ok(()));
    let events = step(&mut m);
    assert!(events
        .iter()
        .any(|e| matches!(e, Event::Transmit { socket_name, .. } if socket_name == SOCKET)));
    let body = "<methodResponse><params><param><value><int>7</int></value></param></params></methodResponse>";
    m.handle_received(SOCKET, format!("HTTP/1.0 200 OK\r\n\r\n{body}").as_bytes());
    step(&mut m);
    assert_eq!(m.state(), &State::Running);
    m.handle_peer_closed(SOCKET);
    // Second call: the server closes half way through a declared body.
    let events = step(&mut m);
    assert_eq!(m.global("x"), Some(&Value::Int(7)));
    assert!(events.iter().any(|e| matches!(e, Event::Connect { .. })));
    m.handle_connected(SOCKET, Ok(()));
    step(&mut m);
    m.handle_received(
        SOCKET,
        b"HTTP/1.0 200 OK\r\nContent-Length: 100\r\n\r\n<methodResp",
    );
    m.handle_peer_closed(SOCKET);
    let events = step(&mut m);
    // The failed call is recorded under its internal socket name, with the reason.
    let failed = events
        .iter()
        .find_map(|e| match e {
            Event::Call(c) => Some(c),
            _ => None,
        })
        .expect("a call record");
    assert_eq!(failed.socket.as_deref(), Some(SOCKET));
    assert!(
        matches!(&failed.outcome, urscript_interp::Outcome::Failed(why) if why.contains("after 11"))
    );
    let State::Error(e) = m.state() else {
        panic!("{:?}", m.state())
    };
    assert!(
        e.message()
            .ends_with("the server closed the connection after 11 of the reply's 100 bytes"),
        "{e}"
    );
}

#[test]
fn factory_and_handle_errors() {
    let err = |src: &str| {
        let h = common::run(src);
        match h.m.state() {
            State::Error(e) => (e.kind(), e.message().to_string()),
            other => panic!("{src}: {other:?}"),
        }
    };
    let (k, m) = err("r = rpc_factory(\"json\", \"http://a/\")\n");
    assert_eq!(k, RuntimeErrorKind::Argument);
    assert!(m.contains("type must be \"xmlrpc\""), "{m}");
    let (_, m) = err("r = rpc_factory(\"xmlrpc\", \"https://a/\")\n");
    assert!(m.contains("only http://"), "{m}");
    // Arguments XML-RPC cannot carry.
    let (k, m) = err(
        "thread t():\nend\nr = rpc_factory(\"xmlrpc\", \"http://a/\")\nh = run t()\nr.f(1, h)\n",
    );
    assert_eq!(k, RuntimeErrorKind::Type);
    assert!(
        m.ends_with("argument 2: a thread cannot be sent over XML-RPC"),
        "{m}"
    );
    let (_, m) = err("r = rpc_factory(\"xmlrpc\", \"http://a/\")\nr.f(1 / 0.0)\n");
    assert!(m.contains("no double for inf"), "{m}");
    // Closing sends nothing: each call had its own connection.
    let h = common::run(
        "r = rpc_factory(\"xmlrpc\", \"http://a/\")\nr.closeXMLRPCClientConnection()\ntextmsg(r)\n",
    );
    assert_eq!(h.m.state(), &State::Finished);
    assert!(h.connects.is_empty());
    assert_eq!(h.messages, ["rpc_factory(\"xmlrpc\", \"http://a/\")"]);
}

/// A tiny XML-RPC server on 127.0.0.1: for each of `calls` connections, reads exactly
/// one request (headers, then Content-Length bytes), answers `answer(body)` in two
/// writes 20 ms apart, and closes.
fn tiny_server(
    calls: usize,
    answer: fn(&str) -> Vec<u8>,
) -> (u16, std::thread::JoinHandle<Vec<String>>) {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = l.local_addr().unwrap().port();
    let t = std::thread::spawn(move || {
        let mut bodies = Vec::new();
        for _ in 0..calls {
            let (s, _) = l.accept().unwrap();
            let mut r = BufReader::new(s);
            let mut length = 0;
            loop {
                let mut line = String::new();
                r.read_line(&mut line).unwrap();
                if line == "\r\n" {
                    break;
                }
                if let Some(v) = line.strip_prefix("Content-Length: ") {
                    length = v.trim().parse().unwrap();
                }
            }
            let mut body = vec![0; length];
            r.read_exact(&mut body).unwrap();
            let body = String::from_utf8(body).unwrap();
            let mut s: TcpStream = r.into_inner();
            // The reply in two segments: the program waits for the whole body.
            let reply = answer(&body);
            let half = reply.len() / 2;
            s.write_all(&reply[..half]).unwrap();
            s.flush().unwrap();
            std::thread::sleep(Duration::from_millis(20));
            s.write_all(&reply[half..]).unwrap();
            bodies.push(body);
        }
        bodies
    });
    (port, t)
}

#[test]
fn over_tcp_through_the_driver() {
    let (port, server) = tiny_server(2, |body| {
        if body.contains("get_position") {
            response(POSE)
        } else {
            response("<string>done</string>")
        }
    });
    let src = format!(
        "rpc = rpc_factory(\"xmlrpc\", \"http://127.0.0.1:{port}/RPC2\")\npos = rpc.get_position(1, \"x\")\nok = rpc.report(pos)\ntextmsg(ok, pos)\n"
    );
    let mut m = Machine::new(Program::parse(&src).unwrap(), Config::default());
    let mut messages = Vec::new();
    let options = Options {
        max_time: Some(Duration::from_secs(20)),
        ..Options::default()
    };
    let outcome = run_tcp(&mut m, &options, |a| {
        if let urscript_interp::drive::Activity::Event(Event::Message(msg)) = a {
            messages.push(msg.text.clone());
        }
    })
    .unwrap();
    assert_eq!(outcome, Outcome::Finished, "{:?}", m.state());
    assert_eq!(messages, ["donep[0.4, -0.2, 0.3, 0, 3.1, 0]"]);
    let bodies = server.join().unwrap();
    assert!(bodies[1].contains("<methodName>report</methodName>"));
    assert!(
        bodies[1].contains("<member><name>ry</name><value><double>3.1</double></value></member>")
    );
}

#[test]
fn against_python_xmlrpc_server() {
    // Python's own XML-RPC server, when python3 is installed (skipped otherwise).
    let script = "import sys\nfrom xmlrpc.server import SimpleXMLRPCServer\ns = SimpleXMLRPCServer(('127.0.0.1', 0), logRequests=False)\ns.register_function(lambda a, b: a + b, 'add')\ns.register_function(lambda p: {'x': p['x'] + 1.0, 'y': p['y'], 'z': p['z'], 'rx': p['rx'], 'ry': p['ry'], 'rz': p['rz']}, 'shift')\ns.register_function(lambda: {'name': 'cam', 'ok': True, 'list': [1, 2.5]}, 'info')\nprint(s.server_address[1], flush=True)\nfor _ in range(4):\n    s.handle_request()\n";
    let Ok(mut child) = std::process::Command::new("python3")
        .args(["-c", script])
        .stdout(std::process::Stdio::piped())
        .spawn()
    else {
        eprintln!("python3 not found: skipped");
        return;
    };
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let port: u16 = line.trim().parse().unwrap();
    let src = format!(
        "rpc = rpc_factory(\"xmlrpc\", \"http://127.0.0.1:{port}/RPC2\")\nn = rpc.add(2, 40)\np = rpc.shift(p[0.1, 0.2, 0.3, 0, 0, 0])\ni = rpc.info()\nm = rpc.missing()\n"
    );
    let mut m = Machine::new(Program::parse(&src).unwrap(), Config::default());
    let options = Options {
        max_time: Some(Duration::from_secs(20)),
        ..Options::default()
    };
    let result = run_tcp(&mut m, &options, |_| {});
    let _ = child.kill();
    let _ = child.wait();
    assert_eq!(m.global("n"), Some(&Value::Int(42)));
    assert_eq!(
        m.global("p"),
        Some(&Value::Pose([1.1, 0.2, 0.3, 0.0, 0.0, 0.0]))
    );
    let Some(Value::Struct(info)) = m.global("i") else {
        panic!("{:?}", m.global("i"))
    };
    assert!(info.contains(&("name".to_string(), Value::Str(b"cam".to_vec()))));
    assert!(info.contains(&("ok".to_string(), Value::Bool(true))));
    // Python answers an unknown method with a fault.
    let Err(e) = result else { panic!("{result:?}") };
    assert_eq!(e.kind(), RuntimeErrorKind::RemoteCall);
    assert!(e.message().contains("fault 1:"), "{e}");
    assert!(e.message().contains("missing"), "{e}");
}

#[test]
fn a_reply_is_held_to_the_value_bounds() {
    let src = format!("rpc = rpc_factory(\"xmlrpc\", \"{URL}\")\nx = rpc.many()\n");
    let config = Config {
        // Above the URL's 29 bytes, below the reply's 100 elements.
        max_value_size: 50,
        ..Config::default()
    };
    let mut h = Harness::new(&src, config);
    let items = "<value><int>1</int></value>".repeat(100);
    let state = serve(&mut h, Duration::ZERO, move |_| {
        response(&format!("<array><data>{items}</data></array>"))
    });
    let State::Error(e) = state else {
        panic!("{state:?}")
    };
    assert_eq!(e.kind(), RuntimeErrorKind::RemoteCall);
    assert!(e.message().contains("more than 50 elements"), "{e}");
    assert_eq!(h.m.global("x"), None);
}

#[test]
fn a_chunked_reply_read_in_pieces_returns_its_value() {
    // Servers that stream their replies (Transfer-Encoding: chunked, no Content-Length)
    // answer in pieces; the call waits for the last chunk, then returns the value.
    let src = format!("rpc = rpc_factory(\"xmlrpc\", \"{URL}\")\nx = rpc.f()\n");
    let mut m = Machine::new(Program::parse(&src).unwrap(), Config::default());
    let mut now = Duration::ZERO;
    let mut step = |m: &mut Machine| {
        m.run_until(now);
        now += Duration::from_millis(2);
        std::iter::from_fn(|| m.poll_event()).collect::<Vec<_>>()
    };
    step(&mut m);
    m.handle_connected(SOCKET, Ok(()));
    step(&mut m);
    let xml = format!(
        "<methodResponse><params><param><value>{POSE}</value></param></params></methodResponse>"
    );
    let (a, b) = xml.split_at(100);
    let reply = format!(
        "HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n{:x}\r\n{a}\r\n{:x}\r\n{b}\r\n0\r\n\r\n",
        a.len(),
        b.len()
    );
    for piece in reply.as_bytes().chunks(37) {
        assert_eq!(m.state(), &State::Running);
        assert_eq!(m.global("x"), None);
        m.handle_received(SOCKET, piece);
        step(&mut m);
    }
    step(&mut m);
    assert_eq!(
        m.global("x"),
        Some(&Value::Pose([0.4, -0.2, 0.3, 0.0, 3.1, 0.0]))
    );
}
