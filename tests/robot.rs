//! The robot emulation: policies (each default and alternative), properties over any
//! chunking, and the virtual robot against a real server over 127.0.0.1.

use std::io::{Read, Write};
use std::net::TcpListener;
use std::time::Duration;

use proptest::prelude::*;
use urscript_socket::ascii_float::{
    encode_float_tuple, ExtraValues, FloatReadPolicy, LeadingBytes, MissingValues,
};
use urscript_socket::int32::encode_int32_list;
use urscript_socket::robot::{
    Policy, ReadCall, ReadResult, Robot, RobotError, ShortRead, SocketConnection, Timeout,
    VirtualRobot,
};
use urscript_socket::string::encode_framed_string;
use urscript_socket::var::{encode_var_reply, VarMessage, VarMessageDecoder};
use urscript_socket::{line::LineDecoder, RecvBuffer};

fn read_now(policy: Policy, input: &[u8], call: ReadCall) -> (String, Vec<u8>) {
    let mut s = SocketConnection::new("socket_0", policy);
    s.receive(input);
    s.start_read(call, Timeout::Forever, Duration::ZERO)
        .unwrap();
    let r = s.poll_read().or_else(|| s.give_up()).unwrap();
    (r.to_urscript(), s.buffered().to_vec())
}

fn float_policy(f: FloatReadPolicy) -> Policy {
    Policy {
        float: f,
        ..Policy::default()
    }
}

#[test]
fn policy_defaults_are_the_spec_defaults() {
    let p = Policy::default();
    assert_eq!(p.float.leading_bytes, LeadingBytes::Skip);
    assert!(p.float.allow_exponent);
    assert_eq!(p.float.extra_values, ExtraValues::Fail);
    assert_eq!(p.float.missing_values, MissingValues::Count);
    assert_eq!(p.short_read, ShortRead::WholeValues);
}

#[test]
fn leading_bytes_skip_and_fail() {
    let call = ReadCall::AsciiFloat { number: 1 };
    assert_eq!(
        read_now(Policy::default(), b"\nxx(5)", call.clone()).0,
        "[1, 5]"
    );
    let fail = float_policy(FloatReadPolicy {
        leading_bytes: LeadingBytes::Fail,
        ..Default::default()
    });
    let (r, rest) = read_now(fail, b"\nxx(5)", call);
    assert_eq!(r, "[0, nan]");
    assert_eq!(rest, b"(5)", "the failed read drops the leading bytes only");
}

#[test]
fn exponent_allowed_and_refused() {
    let call = ReadCall::AsciiFloat { number: 1 };
    assert_eq!(
        read_now(Policy::default(), b"(1e-3)", call.clone()).0,
        "[1, 0.001]"
    );
    let strict = float_policy(FloatReadPolicy {
        allow_exponent: false,
        ..Default::default()
    });
    let (r, rest) = read_now(strict, b"(1e-3)", call);
    assert_eq!(
        (r.as_str(), rest.len()),
        ("[0, nan]", 0),
        "failed and consumed through ')'"
    );
}

#[test]
fn extra_values_fail_and_take_first() {
    let call = ReadCall::AsciiFloat { number: 2 };
    let (r, rest) = read_now(Policy::default(), b"(1,2,3)(4,5)", call.clone());
    assert_eq!(
        (r.as_str(), rest.as_slice()),
        ("[0, nan, nan]", &b"(4,5)"[..])
    );
    let take = float_policy(FloatReadPolicy {
        extra_values: ExtraValues::TakeFirst,
        ..Default::default()
    });
    assert_eq!(read_now(take, b"(1,2,3)", call).0, "[2, 1, 2]");
}

#[test]
fn missing_values_count_and_fail() {
    let call = ReadCall::AsciiFloat { number: 3 };
    assert_eq!(
        read_now(Policy::default(), b"(7)", call.clone()).0,
        "[1, 7, nan, nan]"
    );
    let fail = float_policy(FloatReadPolicy {
        missing_values: MissingValues::Fail,
        ..Default::default()
    });
    assert_eq!(read_now(fail, b"(7)", call).0, "[0, nan, nan, nan]");
}

#[test]
fn short_reads_sentinel_and_whole_values() {
    let input = [0, 0, 0, 7, 0, 0];
    let call = ReadCall::BinaryInteger { number: 3 };
    let sentinel = Policy {
        short_read: ShortRead::Sentinel,
        ..Policy::default()
    };
    let (r, rest) = read_now(sentinel, &input, call.clone());
    assert_eq!((r.as_str(), rest.len()), ("[0, -1, -1, -1]", 6));
    let whole = Policy::default();
    let (r, rest) = read_now(whole, &input, call);
    assert_eq!(
        (r.as_str(), rest.as_slice()),
        ("[1, 7, -1, -1]", &[0u8, 0][..])
    );
    let (r, _) = read_now(whole, b"ab", ReadCall::ByteList { number: 3 });
    assert_eq!(r, "[2, 97, 98, -1]");
}

#[test]
fn malformed_tuple_fails_and_is_consumed() {
    let (r, rest) = read_now(
        Policy::default(),
        b"(1,x,3)(4)",
        ReadCall::AsciiFloat { number: 3 },
    );
    assert_eq!(
        (r.as_str(), rest.as_slice()),
        ("[0, nan, nan, nan]", &b"(4)"[..])
    );
}

#[test]
fn read_string_over_the_limit_and_unseen_suffix() {
    let big = vec![b'a'; 1500];
    let (r, rest) = read_now(
        Policy::default(),
        &big,
        ReadCall::String {
            prefix: vec![],
            suffix: vec![],
            interpret_escape: false,
        },
    );
    assert_eq!((r.len() - 2, rest.len()), (1024, 476));
    let call = ReadCall::String {
        prefix: b">".to_vec(),
        suffix: b"<".to_vec(),
        interpret_escape: false,
    };
    let (r, rest) = read_now(Policy::default(), b"noise>hel", call);
    assert_eq!(
        (r.as_str(), rest.as_slice()),
        ("\"\"", &b"noise>hel"[..]),
        "timeout: buffer unchanged"
    );
}

#[test]
fn peer_close_resolves_every_pending_read() {
    let mut s = SocketConnection::new("socket_0", Policy::default());
    s.receive(b"(1,");
    s.start_read(
        ReadCall::AsciiFloat { number: 2 },
        Timeout::Forever,
        Duration::ZERO,
    )
    .unwrap();
    assert!(s.poll_read().is_none());
    s.peer_closed();
    assert_eq!(s.poll_read().unwrap().to_urscript(), "[0, nan, nan]");
    for (call, want) in [
        (ReadCall::BinaryInteger { number: 1 }, "[0, -1]"),
        (ReadCall::Line, "\"\""),
        (ReadCall::GetVar { name: "A".into() }, "0"),
    ] {
        s.start_read(call, Timeout::Forever, Duration::ZERO)
            .unwrap();
        assert_eq!(s.poll_read().unwrap().to_urscript(), want);
    }
}

#[test]
fn misuse_is_refused_before_any_byte() {
    let mut s = SocketConnection::new("socket_0", Policy::default());
    s.receive(b"(1)");
    for call in [
        ReadCall::AsciiFloat { number: 0 },
        ReadCall::AsciiFloat { number: 31 },
        ReadCall::BinaryInteger { number: 31 },
        ReadCall::ByteList { number: 0 },
        ReadCall::GetVar { name: "a b".into() },
        ReadCall::String {
            prefix: vec![b'x'; 65],
            suffix: vec![],
            interpret_escape: false,
        },
    ] {
        assert!(matches!(
            s.start_read(call, Timeout::Forever, Duration::ZERO),
            Err(RobotError::Argument(_))
        ));
    }
    assert_eq!(s.buffered(), b"(1)");
    assert!(s.outgoing().is_empty());
    s.start_read(ReadCall::Line, Timeout::Forever, Duration::ZERO)
        .unwrap();
    assert!(matches!(
        s.start_read(ReadCall::Line, Timeout::Forever, Duration::ZERO),
        Err(RobotError::ReadPending)
    ));
    assert!(s.set_var("has space", 1).is_err());
}

#[test]
fn named_sockets_are_independent() {
    let mut robot = Robot::new(Policy::default());
    robot.socket_open("a").receive(b"(1)");
    robot.socket_open("b").receive(b"(2)");
    let a = robot.socket("a").unwrap();
    a.start_read(
        ReadCall::AsciiFloat { number: 1 },
        Timeout::Forever,
        Duration::ZERO,
    )
    .unwrap();
    assert_eq!(a.poll_read().unwrap().to_urscript(), "[1, 1]");
    assert_eq!(robot.socket("b").unwrap().buffered(), b"(2)");
}

/// The messages a server sends for a list of reads, and the results the robot must see.
fn messages() -> impl Strategy<Value = Vec<(ReadCall, Vec<u8>, String)>> {
    let floats = prop::collection::vec(prop::num::f64::NORMAL | prop::num::f64::ZERO, 1..=30)
        .prop_map(|v| {
            let mut b = Vec::new();
            encode_float_tuple(&v, false, &mut b).unwrap();
            let want = ReadResult::Floats(
                urscript_socket::ascii_float::FloatTupleDecoder::new(v.len())
                    .unwrap()
                    .decode(&b)
                    .unwrap()
                    .item()
                    .unwrap(),
            );
            // Independent check of the values, bit for bit.
            if let ReadResult::Floats(t) = &want {
                assert!(t
                    .values()
                    .iter()
                    .zip(&v)
                    .all(|(a, b)| a.to_bits() == b.to_bits()));
            }
            let mut text = format!("[{}", v.len());
            for x in &v {
                // The robot's to_str rule: 6 decimals, trailing zeros and point dropped.
                let six = format!("{x:.6}");
                let trimmed = six.trim_end_matches('0').trim_end_matches('.');
                text.push_str(&format!(", {trimmed}"));
            }
            text.push(']');
            (ReadCall::AsciiFloat { number: v.len() }, b, text)
        });
    let ints = prop::collection::vec(any::<i32>(), 1..=30).prop_map(|v| {
        let mut b = Vec::new();
        encode_int32_list(&v, &mut b).unwrap();
        let text = format!(
            "[{}, {}]",
            v.len(),
            v.iter()
                .map(|x| x.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
        (ReadCall::BinaryInteger { number: v.len() }, b, text)
    });
    let bytes = prop::collection::vec(any::<u8>(), 1..=30).prop_map(|v| {
        let text = format!(
            "[{}, {}]",
            v.len(),
            v.iter()
                .map(|x| x.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
        (ReadCall::ByteList { number: v.len() }, v, text)
    });
    let strings = "[a-z ]{0,40}".prop_map(|t| {
        let mut b = Vec::new();
        encode_framed_string(b">", t.as_bytes(), b"<", &mut b).unwrap();
        let call = ReadCall::String {
            prefix: b">".to_vec(),
            suffix: b"<".to_vec(),
            interpret_escape: false,
        };
        (call, b, format!("\"{t}\""))
    });
    let lines = "[a-z ]{0,40}".prop_map(|t| {
        (
            ReadCall::Line,
            format!("{t}\r\n").into_bytes(),
            format!("\"{t}\""),
        )
    });
    let vars = any::<i32>().prop_map(|v| {
        let mut b = Vec::new();
        encode_var_reply("POS", v, &mut b).unwrap();
        (ReadCall::GetVar { name: "POS".into() }, b, v.to_string())
    });
    prop::collection::vec(
        prop_oneof![floats, ints, bytes, strings, lines, vars],
        1..12,
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    /// Server-side encode -> robot-side read gives `[n, values...]`, whatever the chunking
    /// and however often the robot polls (timeouts that do not expire).
    #[test]
    fn any_chunking_gives_the_same_results(msgs in messages(), chunk in 1usize..40, polls in 1usize..4) {
        let stream: Vec<u8> = msgs.iter().flat_map(|(_, b, _)| b.clone()).collect();
        let mut s = SocketConnection::new("socket_0", Policy::default());
        let mut fed = 0;
        for (call, _, want) in &msgs {
            s.start_read(call.clone(), Timeout::Forever, Duration::ZERO).unwrap();
            let result = loop {
                let mut got = None;
                for _ in 0..polls {
                    got = got.or_else(|| s.poll_read());
                }
                if let Some(r) = got {
                    break r;
                }
                prop_assert!(fed < stream.len(), "ran out of input for {call:?}");
                let end = (fed + chunk).min(stream.len());
                prop_assert_eq!(s.receive(&stream[fed..end]), end - fed);
                fed = end;
            };
            prop_assert_eq!(&result.to_urscript(), want);
        }
    }
}

/// A small server written with the core codec: answers the robot's requests by the first
/// word of each line, and SET/GET variables.
fn serve(listener: TcpListener) {
    let (mut robot, _) = listener.accept().unwrap();
    let mut rx = RecvBuffer::with_capacity(4096);
    let mut lines = LineDecoder::new();
    let mut vars: Vec<(String, i32)> = Vec::new();
    loop {
        let n = robot.read(rx.spare()).unwrap();
        if n == 0 {
            return;
        }
        rx.commit(n);
        while let Some(line) = rx.decode(&mut lines).unwrap() {
            let mut reply = Vec::new();
            match urscript_socket::var::parse_var_message(line) {
                Ok(VarMessage::Set { name, value }) => vars.push((name.to_string(), value)),
                Ok(VarMessage::Get { name }) => {
                    let v = vars
                        .iter()
                        .rev()
                        .find(|(n, _)| n == name)
                        .map_or(0, |(_, v)| *v);
                    encode_var_reply(name, v, &mut reply).unwrap();
                }
                Err(_) => match line {
                    b"floats" => encode_float_tuple(&[0.5, -1.25, 3.0], false, &mut reply)
                        .map(drop)
                        .unwrap(),
                    b"ints" => encode_int32_list(&[1, -2, 300000], &mut reply)
                        .map(drop)
                        .unwrap(),
                    b"bytes" => reply.extend_from_slice(&[2, 200, 3]),
                    b"string" => encode_framed_string(b"<", b"ok", b">", &mut reply)
                        .map(drop)
                        .unwrap(),
                    b"line" => reply.extend_from_slice(b"done\r\n"),
                    _ => {} // "silent": no reply, the robot times out
                },
            }
            robot.write_all(&reply).unwrap();
        }
    }
}

#[test]
fn virtual_robot_against_a_core_server_over_loopback() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let server = std::thread::spawn(move || serve(listener));
    let mut robot = VirtualRobot::new(Policy::default());
    let s = "camera";
    let t = Timeout::from_secs_f64(5.0);
    assert!(robot.socket_open(addr, s).unwrap());

    robot.socket_send_line(b"floats", s).unwrap();
    assert_eq!(
        robot.socket_read_ascii_float(3, s, t).unwrap().values(),
        [0.5, -1.25, 3.0]
    );
    robot.socket_send_line(b"ints", s).unwrap();
    assert_eq!(
        robot.socket_read_binary_integer(3, s, t).unwrap().values(),
        [1, -2, 300000]
    );
    robot.socket_send_line(b"bytes", s).unwrap();
    assert_eq!(
        robot.socket_read_byte_list(3, s, t).unwrap().values(),
        [2, 200, 3]
    );
    robot.socket_send_line(b"string", s).unwrap();
    assert_eq!(
        robot.socket_read_string(s, b"<", b">", false, t).unwrap(),
        b"ok"
    );
    robot.socket_send_line(b"line", s).unwrap();
    assert_eq!(robot.socket_read_line(s, t).unwrap(), b"done");
    robot.socket_set_var("POS_X", 1234, s).unwrap();
    assert_eq!(robot.socket_get_var("POS_X", s).unwrap(), 1234);

    robot.socket_send_line(b"silent", s).unwrap();
    let timed_out = robot
        .socket_read_ascii_float(2, s, Timeout::from_secs_f64(0.2))
        .unwrap();
    assert_eq!(timed_out.count(), 0);
    assert!(timed_out.values().iter().all(|v| v.is_nan()));

    assert!(matches!(
        robot.socket_read_line("nope", t),
        Err(RobotError::NotOpen(_))
    ));
    assert!(robot.socket_close(s));
    server.join().unwrap();
}

#[test]
fn virtual_robot_sees_peer_close_as_sentinel() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let server = std::thread::spawn(move || {
        let (mut c, _) = listener.accept().unwrap();
        c.write_all(b"(1,").unwrap(); // half a tuple, then close
    });
    let mut robot = VirtualRobot::new(Policy::default());
    assert!(robot.socket_open(addr, "s").unwrap());
    server.join().unwrap();
    let r = robot
        .socket_read_ascii_float(2, "s", Timeout::Forever)
        .unwrap();
    assert_eq!(r.count(), 0);
    // A server that is not there: socket_open returns False, as on the robot.
    let gone = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap();
    assert!(!robot.socket_open(gone, "t").unwrap());
}

#[test]
fn var_message_decoder_matches_the_robot_sends() {
    let mut s = SocketConnection::new("socket_0", Policy::default());
    s.set_var("A", -5).unwrap();
    s.start_read(
        ReadCall::GetVar { name: "A".into() },
        Timeout::Forever,
        Duration::ZERO,
    )
    .unwrap();
    let out = s.take_outgoing();
    let mut d = VarMessageDecoder::new();
    let first = d.decode(&out).unwrap();
    let used = first.consumed();
    assert_eq!(
        first.item(),
        Some(VarMessage::Set {
            name: "A",
            value: -5
        })
    );
    assert_eq!(
        d.decode(&out[used..]).unwrap().item(),
        Some(VarMessage::Get { name: "A" })
    );
}

// ---- The robot as a state machine with time as an input (no sleeps, no clock) ----

#[test]
fn deadlines_are_inputs_and_resolve_exactly_at_their_moment() {
    let ms = Duration::from_millis;
    let mut s = SocketConnection::new("s", Policy::default());
    assert_eq!(s.poll_timeout(), None);
    s.start_read(ReadCall::Line, Timeout::from_secs_f64(0.25), ms(1_000))
        .unwrap();
    assert_eq!(s.poll_timeout(), Some(ms(1_250)));
    assert!(s.poll_read().is_none());
    assert!(s.handle_timeout(ms(1_249)).is_none());
    assert!(s.pending_read().is_some());
    s.receive(b"partial");
    assert!(s.poll_read().is_none());
    assert_eq!(s.handle_timeout(ms(1_250)).unwrap().to_urscript(), "\"\"");
    assert_eq!(s.poll_timeout(), None);
    // The bytes stay for the next read, which completes before its deadline.
    s.start_read(ReadCall::Line, Timeout::from_secs_f64(1.0), ms(2_000))
        .unwrap();
    s.receive(b"\n");
    assert_eq!(s.poll_read().unwrap().to_urscript(), "\"partial\"");
    assert!(s.handle_timeout(ms(9_999)).is_none());
}

#[test]
fn get_var_waits_two_seconds_whatever_is_asked() {
    let mut s = SocketConnection::new("s", Policy::default());
    let call = ReadCall::GetVar { name: "X".into() };
    s.start_read(call, Timeout::Forever, Duration::from_secs(5))
        .unwrap();
    assert_eq!(s.poll_timeout(), Some(Duration::from_secs(7)));
}

#[test]
fn huge_timeouts_mean_forever_not_overflow() {
    // timeout=1e19 used to overflow `Instant + Duration` in the drivers.
    let mut s = SocketConnection::new("s", Policy::default());
    s.start_read(
        ReadCall::Line,
        Timeout::from_secs_f64(1e19),
        Duration::from_secs(10),
    )
    .unwrap();
    assert!(s.poll_timeout().unwrap() > Duration::from_secs(1 << 62));
    assert!(s.handle_timeout(Duration::from_secs(1 << 40)).is_none());
    s.give_up();
    s.start_read(ReadCall::Line, Timeout::After(Duration::MAX), Duration::MAX)
        .unwrap();
    assert_eq!(s.poll_timeout(), None);
}

#[test]
fn a_read_that_can_never_complete_ends_at_its_deadline_or_at_once_without_one() {
    let small = Policy {
        receive_capacity: 8,
        ..Policy::default()
    };
    let mut s = SocketConnection::new("s", small);
    s.receive(b"(1,2,3,4");
    s.start_read(
        ReadCall::AsciiFloat { number: 9 },
        Timeout::from_secs_f64(1.0),
        Duration::ZERO,
    )
    .unwrap();
    assert!(s.poll_read().is_none(), "waits for its deadline");
    assert!(s.handle_timeout(Duration::from_secs(1)).is_some());
    s.start_read(
        ReadCall::AsciiFloat { number: 9 },
        Timeout::Forever,
        Duration::ZERO,
    )
    .unwrap();
    assert_eq!(
        s.poll_read().unwrap().to_urscript(),
        "[0, nan, nan, nan, nan, nan, nan, nan, nan, nan]"
    );
}

#[test]
fn robot_table_wakes_at_the_earliest_deadline() {
    let mut robot = Robot::new(Policy::default());
    for (name, secs) in [("a", 2.0), ("b", 0.5), ("c", 0.0)] {
        robot
            .socket_open(name)
            .start_read(
                ReadCall::Line,
                Timeout::from_secs_f64(secs),
                Duration::from_secs(1),
            )
            .unwrap();
    }
    assert_eq!(robot.poll_timeout(), Some(Duration::from_millis(1_500)));
    let b = robot.socket("b").unwrap();
    assert!(b.handle_timeout(Duration::from_millis(1_500)).is_some());
    assert_eq!(robot.poll_timeout(), Some(Duration::from_secs(3)));
}

#[test]
fn sends_after_a_failed_send_return_false_and_the_program_goes_on() {
    let mut s = SocketConnection::new("s", Policy::default());
    assert!(s.send_int(1));
    s.send_failed();
    assert!(!s.send_int(1));
    assert!(!s.send_line(b"x"));
    assert!(!s.send_byte(2));
    assert!(!s.set_var("X", 1).unwrap());
    assert!(s.outgoing().is_empty());
    // Reads still work on what arrived.
    s.receive(b"ok\n");
    s.start_read(ReadCall::Line, Timeout::default(), Duration::ZERO)
        .unwrap();
    assert_eq!(s.poll_read().unwrap().to_urscript(), "\"ok\"");
}

#[test]
fn virtual_robot_huge_timeout_does_not_panic() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let server = std::thread::spawn(move || {
        let (mut robot, _) = listener.accept().unwrap();
        robot.write_all(b"(1,2)").unwrap();
    });
    let mut robot = VirtualRobot::new(Policy::default());
    assert!(robot.socket_open(addr, "s").unwrap());
    let t = robot
        .socket_read_ascii_float(2, "s", Timeout::from_secs_f64(1e19))
        .unwrap();
    assert_eq!(t.values(), [1.0, 2.0]);
    server.join().unwrap();
}

#[test]
fn virtual_robot_sends_to_a_closed_server_return_false() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let server = std::thread::spawn(move || {
        let (robot, _) = listener.accept().unwrap();
        drop(robot);
    });
    let mut robot = VirtualRobot::new(Policy::default());
    assert!(robot.socket_open(addr, "s").unwrap());
    server.join().unwrap();
    // The first writes may still be accepted by the kernel; once the peer's RST
    // arrives a write fails, and from then on every send is false, never an error.
    let mut results = Vec::new();
    for _ in 0..200 {
        results.push(robot.socket_send_line(b"hello", "s").unwrap());
        std::thread::sleep(Duration::from_millis(1));
    }
    assert_eq!(results.last(), Some(&false), "{results:?}");
    let first_false = results.iter().position(|r| !r).unwrap();
    assert!(results[first_false..].iter().all(|r| !r));
    assert!(!robot.socket_send_int(7, "s").unwrap());
    // Reads resolve to sentinels: the program goes on.
    let r = robot
        .socket_read_line("s", Timeout::from_secs_f64(0.2))
        .unwrap();
    assert!(r.is_empty());
}

#[test]
fn virtual_robot_says_why_socket_open_failed() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    drop(listener);
    let mut robot = VirtualRobot::new(Policy::default());
    assert!(!robot.socket_open(addr, "s").unwrap());
    assert_eq!(
        robot.last_open_error().unwrap().kind(),
        std::io::ErrorKind::ConnectionRefused
    );
}

/// One text writer: a read's result prints as the robot's own `to_str` text, the form
/// the same program uses for a pose literal (it printed `3.14159265` before).
#[test]
fn read_results_print_by_the_robots_to_str_rules() {
    let (text, _) = read_now(
        Policy::default(),
        b"(3.14159265,2.5)",
        ReadCall::AsciiFloat { number: 2 },
    );
    assert_eq!(text, "[2, 3.141593, 2.5]");
    let mut pose = String::new();
    urscript_socket::to_str::write_value(
        &urscript_socket::to_str::Value::Pose([1.23456789, 0.0, 0.0, 0.0, 0.0, 1e-9]),
        &mut pose,
    )
    .unwrap();
    assert_eq!(pose, "p[1.234568, 0, 0, 0, 0, 0]");
}

/// A `read_string` whose prefix never arrives used to wedge the socket: 100 kB of junk
/// filled the receive buffer and `>ok<` behind it was never read.
#[test]
fn junk_before_a_prefix_does_not_wedge_the_socket() {
    let mut s = SocketConnection::new("s", Policy::default());
    let call = ReadCall::String {
        prefix: b">".to_vec(),
        suffix: b"<".to_vec(),
        interpret_escape: false,
    };
    s.start_read(call, Timeout::from_secs_f64(2.0), Duration::ZERO)
        .unwrap();
    let mut input = vec![b'x'; 100_000];
    input.extend_from_slice(b">ok<");
    let mut offered = &input[..];
    let mut result = None;
    for _ in 0..1_000 {
        let n = s.receive(offered);
        offered = &offered[n..];
        if let Some(r) = s.poll_read() {
            result = Some(r);
            break;
        }
    }
    assert_eq!(result.unwrap().to_urscript(), "\"ok\"");
    assert!(s.buffered().len() <= Policy::default().receive_capacity);
}

/// `next(now)`: a full buffer without a complete message leaves only the deadline, so the
/// step says sleep until it, and at the deadline the read ends with its sentinel.
#[test]
fn next_sleeps_on_a_full_buffer_until_the_deadline() {
    use urscript_socket::robot::Step;
    let policy = Policy {
        receive_capacity: 4,
        ..Policy::default()
    };
    let mut s = SocketConnection::new("s", policy);
    s.start_read(ReadCall::Line, Timeout::from_secs_f64(0.5), Duration::ZERO)
        .unwrap();
    let until = Duration::from_millis(500);
    assert_eq!(
        s.next(Duration::ZERO),
        Step::NeedBytes { until: Some(until) }
    );
    assert_eq!(s.receive(b"abcdef"), 4);
    assert_eq!(s.next(Duration::from_millis(1)), Step::Sleep { until });
    match s.next(until) {
        Step::Done(r) => assert_eq!(r.to_urscript(), "\"\""),
        other => panic!("{other:?}"),
    }
    assert_eq!(s.next(until), Step::Idle);
}
