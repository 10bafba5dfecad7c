//! Issue 11: `ursock robot --script FILE` runs whole URScript programs (threads, loops,
//! functions, built-ins) in real time against servers on 127.0.0.1. Every program here
//! was written for these tests in the style of real ones; none is copied.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::process::{Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

fn ursock() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ursock"))
}

/// Writes `program` to a temporary file and runs `ursock robot --script FILE extra...`;
/// returns (exit code, stdout, stderr).
fn run_program(name: &str, program: &str, extra: &[&str]) -> (i32, String, String) {
    let path = std::env::temp_dir().join(format!("ursock-{name}-{}.script", std::process::id()));
    std::fs::write(&path, program).unwrap();
    let out = ursock()
        .args(["robot", "--script", path.to_str().unwrap()])
        .args(extra)
        .stdin(Stdio::null())
        .output()
        .expect("spawn ursock");
    let _ = std::fs::remove_file(&path);
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn listener() -> (TcpListener, u16) {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = l.local_addr().unwrap().port();
    (l, port)
}

fn read_exact_or_none(s: &mut TcpStream, n: usize) -> Option<Vec<u8>> {
    let mut buf = vec![0u8; n];
    s.read_exact(&mut buf).ok().map(|()| buf)
}

fn read_until(s: &mut TcpStream, end: u8) -> Option<Vec<u8>> {
    let mut out = Vec::new();
    let mut b = [0u8; 1];
    loop {
        match s.read(&mut b) {
            Ok(1) => {
                if b[0] == end {
                    return Some(out);
                }
                out.push(b[0]);
            }
            _ => return None,
        }
    }
}

fn int32s(values: &[i32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_be_bytes()).collect()
}

// ---------------------------------------------------------------------------------------
// An External-Control-like program: three sockets, a servo thread at the step rate, a
// script-command thread, int32 messages, results sent back with socket_send_int.

const EXTERNAL_CONTROL_LIKE: &str = r#"# External-Control-like robot program (written for this test).
def ext_control():
  global MULT_JOINTSTATE = 1000000.0
  global MODE_STOPPED = -2
  global MODE_SERVOJ = 1
  global MODE_TRAJECTORY = 2
  global cmd_servo_q = get_actual_joint_positions()
  global cmd_servo_state = 0
  global servo_count = 0
  global keep_running = True

  def set_servo_setpoint(q):
    enter_critical
    cmd_servo_q = q
    cmd_servo_state = 1
    exit_critical
  end

  def q_from(msg, first):
    return [msg[first] / MULT_JOINTSTATE, msg[first + 1] / MULT_JOINTSTATE,
            msg[first + 2] / MULT_JOINTSTATE, msg[first + 3] / MULT_JOINTSTATE,
            msg[first + 4] / MULT_JOINTSTATE, msg[first + 5] / MULT_JOINTSTATE]
  end

  thread servoThread():
    while keep_running:
      enter_critical
      local q = cmd_servo_q
      local do_servo = cmd_servo_state == 1
      exit_critical
      if do_servo:
        servoj(q, t=get_steptime(), lookahead_time=0.03, gain=300)
        servo_count = servo_count + 1
      else:
        sync()
      end
    end
  end

  thread scriptCommandThread():
    while keep_running:
      local cmd = socket_read_binary_integer(2, "script_command_socket", 0.05)
      if cmd[0] == 2:
        if cmd[1] == 1:
          set_payload(cmd[2] / 1000.0)
          socket_send_int(1, "script_command_socket")
        end
      end
    end
  end

  socket_open("127.0.0.1", REVERSE_PORT, "reverse_socket")
  socket_open("127.0.0.1", TRAJECTORY_PORT, "trajectory_socket")
  socket_open("127.0.0.1", COMMAND_PORT, "script_command_socket")
  servo = run servoThread()
  commands = run scriptCommandThread()
  textmsg("External Control: connected")
  params = socket_read_binary_integer(8, "reverse_socket", 2.0)
  while params[0] > 0:
    mode = params[8]
    if mode == MODE_STOPPED:
      break
    elif mode == MODE_SERVOJ:
      set_servo_setpoint(q_from(params, 2))
    elif mode == MODE_TRAJECTORY:
      n = params[2]
      done = 0
      while done < n:
        point = socket_read_binary_integer(7, "trajectory_socket", 1.0)
        if point[0] != 7:
          break
        end
        movej(q_from(point, 1), t=point[7] / 1000.0)
        done = done + 1
      end
      if done == n:
        socket_send_int(0, "trajectory_socket")
      else:
        socket_send_int(1, "trajectory_socket")
      end
    end
    params = socket_read_binary_integer(8, "reverse_socket", params[1] / 1000.0)
  end
  keep_running = False
  join servo
  join commands
  socket_send_int(servo_count, "reverse_socket")
  textmsg("session complete, servo steps: ", servo_count)
  socket_close("reverse_socket")
  socket_close("trajectory_socket")
  socket_close("script_command_socket")
end
"#;

/// The driver side: the reverse interface, the trajectory interface and the script
/// command interface of the crate's External Control example (8 int32 per reverse
/// message: read timeout in ms, six joint values × 1e6, mode).
fn external_control_server(
    reverse: TcpListener,
    trajectory: TcpListener,
    command: TcpListener,
) -> thread::JoinHandle<(i32, i32, i32)> {
    thread::spawn(move || {
        let (mut rev, _) = reverse.accept().unwrap();
        let (mut traj, _) = trajectory.accept().unwrap();
        let (mut cmd, _) = command.accept().unwrap();
        // Script command: set the payload to 1.5 kg; the robot acknowledges with 1.
        cmd.write_all(&int32s(&[1, 1500])).unwrap();
        let ack = i32::from_be_bytes(read_exact_or_none(&mut cmd, 4).unwrap().try_into().unwrap());
        // Ten servoj set-points, 20 ms apart, each allowing 100 ms until the next.
        for i in 0..10 {
            let t = i as f64 * 0.01;
            let q = [t, -1.57 + t, 1.57, -1.57, -1.57, 0.0];
            let mut msg = vec![100];
            msg.extend(q.iter().map(|x| (x * 1e6).round() as i32));
            msg.push(1);
            rev.write_all(&int32s(&msg)).unwrap();
            thread::sleep(Duration::from_millis(20));
        }
        // A trajectory of three points (six joints × 1e6, 100 ms each).
        rev.write_all(&int32s(&[1000, 3, 0, 0, 0, 0, 0, 2]))
            .unwrap();
        for k in 0..3 {
            let mut p: Vec<i32> = (0..6).map(|j| k * 100_000 + j * 10_000).collect();
            p.push(100);
            traj.write_all(&int32s(&p)).unwrap();
        }
        let result = i32::from_be_bytes(
            read_exact_or_none(&mut traj, 4)
                .unwrap()
                .try_into()
                .unwrap(),
        );
        // Stop.
        rev.write_all(&int32s(&[0, 0, 0, 0, 0, 0, 0, -2])).unwrap();
        let servo_steps =
            i32::from_be_bytes(read_exact_or_none(&mut rev, 4).unwrap().try_into().unwrap());
        (ack, result, servo_steps)
    })
}

#[test]
fn an_external_control_like_program_runs_its_session_to_the_end() {
    let (reverse, rp) = listener();
    let (trajectory, tp) = listener();
    let (command, cp) = listener();
    let server = external_control_server(reverse, trajectory, command);
    let program = EXTERNAL_CONTROL_LIKE
        .replace("REVERSE_PORT", &rp.to_string())
        .replace("TRAJECTORY_PORT", &tp.to_string())
        .replace("COMMAND_PORT", &cp.to_string());
    let (code, out, err) = run_program("extctl", &program, &["--max-time", "20"]);
    assert_eq!(code, 0, "{out}\n{err}");
    let (ack, result, servo_steps) = server.join().unwrap();
    assert_eq!(ack, 1, "the script command was acknowledged");
    assert_eq!(result, 0, "the trajectory succeeded");
    // The servo thread ran at the 2 ms step for the ~200 ms of set-points.
    assert!(servo_steps > 20, "{servo_steps} servo steps\n{out}");
    assert!(out.contains("External Control: connected"), "{out}");
    assert!(
        out.contains(&format!("session complete, servo steps: {servo_steps}")),
        "{out}"
    );
    // Each socket call is printed with what it returned.
    assert!(
        out.contains("params = socket_read_binary_integer(8, \"reverse_socket\", 0.1) -> [8, 100, 10000, -1560000,"),
        "{out}"
    );
    assert!(
        out.contains("socket_send_int(0, \"trajectory_socket\") -> True"),
        "{out}"
    );
    assert!(!out.contains("--max-time"), "{err}");
}

// ---------------------------------------------------------------------------------------
// A vision pick loop.

const VISION_PICK: &str = r#"# Vision pick loop (written for this test)
global CAM = "camera"
global picks = 0
global approach = 0.10
def pick_at(pose):
  above = pose_trans(pose, p[0, 0, -approach, 0, 0, 0])
  movel(above, a=1.2, v=0.25)
  movel(pose, a=0.5, v=0.1)
  set_standard_digital_out(0, True)
  movel(above, a=1.2, v=0.25)
end
if not socket_open("127.0.0.1", CAM_PORT, CAM):
  popup("camera not reachable", "Vision", error=True)
  halt
end
while picks < 3:
  socket_send_line(str_cat("shoot ", picks + 1), CAM)
  r = socket_read_ascii_float(6, CAM, timeout=2)
  if r[0] == 6:
    target = p[r[1] / 1000, r[2] / 1000, r[3] / 1000, r[4], r[5], r[6]]
    pick_at(target)
    picks = picks + 1
  else:
    textmsg("no part found, r[0] = ", r[0])
    break
  end
end
socket_send_line("done", CAM)
textmsg("picked ", picks)
socket_close(CAM)
"#;

#[test]
fn a_vision_pick_loop_moves_to_each_pose_the_camera_sends() {
    let (l, port) = listener();
    let server = thread::spawn(move || {
        let (mut s, _) = l.accept().unwrap();
        let mut requests = Vec::new();
        loop {
            let line = String::from_utf8(read_until(&mut s, b'\n').unwrap()).unwrap();
            if line == "done" {
                return requests;
            }
            let n: f64 = line.strip_prefix("shoot ").unwrap().parse().unwrap();
            s.write_all(format!("({}, -200.5, 300, 0, 3.14159, 0)\n", 400.0 + n).as_bytes())
                .unwrap();
            requests.push(line);
        }
    });
    let program = VISION_PICK.replace("CAM_PORT", &port.to_string());
    let (code, out, err) = run_program("vision", &program, &[]);
    assert_eq!(code, 0, "{out}\n{err}");
    assert_eq!(server.join().unwrap(), ["shoot 1", "shoot 2", "shoot 3"]);
    assert!(
        out.contains("r = socket_read_ascii_float(6, \"camera\", timeout=2) -> [6, 403, -200.5, 300, 0, 3.14159, 0]"),
        "{out}"
    );
    assert!(out.contains("picked 3"), "{out}");
}

// ---------------------------------------------------------------------------------------
// A gripper daemon: set_var/get_var in a while with a timeout counter, against
// `ursock listen` (which answers GET from what was SET).

const GRIPPER_DAEMON: &str = r#"# Gripper daemon (written for this test)
def gripper_daemon():
  global GRIP = "gripper"
  def grip_wait(var, expected, max_polls):
    local polls = 0
    local value = socket_get_var(var, GRIP)
    while value != expected and polls < max_polls:
      sleep(0.02)
      polls = polls + 1
      value = socket_get_var(var, GRIP)
    end
    return polls < max_polls
  end
  socket_open("127.0.0.1", GRIP_PORT, GRIP)
  socket_set_var("ACT", 1, GRIP)
  socket_set_var("GTO", 1, GRIP)
  socket_set_var("POS", 200, GRIP)
  if grip_wait("POS", 200, 10):
    textmsg("gripper at 200")
  end
  if not grip_wait("OBJ", 2, 5):
    textmsg("no object detected after 5 polls")
  end
  socket_close(GRIP)
end
"#;

#[test]
fn a_gripper_daemon_polls_variables_of_ursock_listen_with_a_timeout_counter() {
    let mut listen = ursock()
        .args([
            "listen",
            "--bind",
            "127.0.0.1",
            "--port",
            "0",
            "--exit-after",
            "1",
            "--quiet",
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(listen.stdout.take().unwrap()).lines();
    let first = lines.next().unwrap().unwrap();
    let addr = first
        .strip_prefix("listening on ")
        .expect(&first)
        .to_string();
    let port = addr.rsplit_once(':').unwrap().1;
    let program = GRIPPER_DAEMON.replace("GRIP_PORT", port);
    let (code, out, err) = run_program("gripper", &program, &[]);
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(
        out.contains("socket_get_var(\"POS\", \"gripper\") -> 200"),
        "{out}"
    );
    assert!(out.contains("gripper at 200"), "{out}");
    // OBJ was never set: the server answers 0, six times (the first and 5 polls).
    assert_eq!(
        out.matches("socket_get_var(\"OBJ\", \"gripper\") -> 0")
            .count(),
        6,
        "{out}"
    );
    assert!(out.contains("no object detected after 5 polls"), "{out}");
    assert!(listen.wait().unwrap().success());
}

// ---------------------------------------------------------------------------------------
// A KEYENCE-style program: commands framed with socket_send_byte(13), replies read with
// socket_read_string and a CR suffix.

const KEYENCE_STYLE: &str = r#"# KEYENCE-style vision sensor dialogue (written for this test)
global CAM = "vs"
def vs_command(cmd):
  socket_send_string(cmd, CAM)
  socket_send_byte(13, CAM)
  local reply = socket_read_string(CAM, suffix="\r", interpret_escape=True, timeout=2)
  return reply
end
socket_open("127.0.0.1", VS_PORT, CAM)
reply = vs_command("TRG")
if reply != "TRG":
  popup(str_cat("unexpected reply: ", reply))
  halt
end
result = vs_command("RBCP,1")
if str_find(result, "RBCP,1,") == 0:
  x = to_num(str_sub(result, 7, 8))
  textmsg("x = ", x)
end
socket_close(CAM)
"#;

#[test]
fn a_keyence_style_program_frames_with_cr() {
    let (l, port) = listener();
    let server = thread::spawn(move || {
        let (mut s, _) = l.accept().unwrap();
        let mut got = Vec::new();
        while let Some(cmd) = read_until(&mut s, b'\r') {
            let cmd = String::from_utf8(cmd).unwrap();
            let reply = match cmd.as_str() {
                "TRG" => "TRG\r".to_string(),
                "RBCP,1" => "RBCP,1,+123.456,-045.000\r".to_string(),
                other => format!("ER,{other},22\r"),
            };
            s.write_all(reply.as_bytes()).unwrap();
            got.push(cmd);
        }
        got
    });
    let program = KEYENCE_STYLE.replace("VS_PORT", &port.to_string());
    let (code, out, err) = run_program("keyence", &program, &[]);
    assert_eq!(code, 0, "{out}\n{err}");
    assert_eq!(server.join().unwrap(), ["TRG", "RBCP,1"]);
    assert!(
        out.contains("socket_send_byte(13, \"vs\") -> True"),
        "{out}"
    );
    assert!(out.contains("-> \"RBCP,1,+123.456,-045.000\""), "{out}");
    assert!(out.contains("x = 123.456"), "{out}");
}

// ---------------------------------------------------------------------------------------
// Options and errors.

#[test]
fn max_time_ends_an_endless_loop_with_success() {
    let (l, port) = listener();
    let server = thread::spawn(move || {
        let (mut s, _) = l.accept().unwrap();
        let mut all = Vec::new();
        let _ = s.read_to_end(&mut all);
        all
    });
    let program = format!(
        "socket_open(\"127.0.0.1\", {port})\nwhile True:\n  socket_send_line(\"tick\")\n  sleep(0.05)\nend\n"
    );
    let start = Instant::now();
    let (code, out, err) = run_program("endless", &program, &["--max-time", "0.5"]);
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(start.elapsed() < Duration::from_secs(5));
    assert!(err.contains("--max-time"), "{err}");
    let sent = String::from_utf8(server.join().unwrap()).unwrap();
    let ticks = sent.matches("tick\n").count();
    assert!((5..=12).contains(&ticks), "{ticks} ticks in 0.5 s");
    // A runtime error before --max-time still fails.
    let (code, _, err) = run_program(
        "endless2",
        "l = [1, 2]\nx = 0\nwhile True:\n  x = x + l[x]\n  sync()\nend\n",
        &["--max-time", "1"],
    );
    assert_ne!(code, 0);
    assert!(err.contains("line 4:"), "{err}");
}

#[test]
fn step_time_sets_get_steptime_and_the_sync_rate() {
    let (code, out, err) = run_program(
        "steptime",
        "textmsg(\"step \", get_steptime())\n",
        &["--step-time", "0.008"],
    );
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("step 0.008"), "{out}");
    let (code, _, err) = run_program("steptime2", "sync()\n", &["--step-time", "0"]);
    assert_ne!(code, 0);
    assert!(err.contains("--step-time"), "{err}");
}

#[test]
fn stubs_stand_in_for_functions_the_virtual_robot_lacks() {
    let (l, port) = listener();
    let server = thread::spawn(move || {
        let (mut s, _) = l.accept().unwrap();
        read_exact_or_none(&mut s, 4).map(|b| i32::from_be_bytes(b.try_into().unwrap()))
    });
    let program = format!(
        "rq_activate_and_wait()\nsocket_open(\"127.0.0.1\", {port})\npos = rq_current_pos()\nsocket_send_int(pos + 1)\n"
    );
    let (code, out, err) = run_program(
        "stub",
        &program,
        &[
            "--stub",
            "rq_activate_and_wait",
            "--stub",
            "rq_current_pos=41",
        ],
    );
    assert_eq!(code, 0, "{out}\n{err}");
    assert_eq!(server.join().unwrap(), Some(42));
    assert!(out.contains("rq_current_pos() -> 41 (stub)"), "{out}");
    // Without the stub: an error naming the function and its line.
    let (code, _, err) = run_program("nostub", "x = 1\nrq_activate_and_wait()\n", &[]);
    assert_ne!(code, 0);
    assert!(
        err.contains("line 2:") && err.contains("rq_activate_and_wait"),
        "{err}"
    );
    let (code, _, err) = run_program("badstub", "x = 1\n", &["--stub", "a=1 +"]);
    assert_ne!(code, 0);
    assert!(err.contains("--stub"), "{err}");
}

#[test]
fn a_urcap_preamble_defines_what_the_program_calls() {
    let (l, port) = listener();
    let server = thread::spawn(move || {
        let (mut s, _) = l.accept().unwrap();
        read_until(&mut s, b'\n')
    });
    // A preamble written for this test in the style of a gripper URCap's.
    let preamble = std::env::temp_dir().join(format!("ursock-urcap-{}.script", std::process::id()));
    std::fs::write(
        &preamble,
        format!("gripper_host = \"127.0.0.1\"\ndef gripper_close(force):\n  socket_open(gripper_host, {port}, \"gripper\")\n  socket_send_line(str_cat(\"CLOSE \", force), \"gripper\")\n  return True\nend\n"),
    )
    .unwrap();
    let program = "def pick():\n  if gripper_close(40):\n    textmsg(\"closed\")\n  end\nend\n";
    let (code, out, err) = run_program(
        "preamble",
        program,
        &["--preamble", preamble.to_str().unwrap()],
    );
    assert_eq!(code, 0, "{out}\n{err}");
    assert_eq!(server.join().unwrap().as_deref(), Some(&b"CLOSE 40"[..]));
    assert!(out.contains("closed"), "{out}");
    // Without it the program is refused before it starts, naming the function.
    let (code, _, err) = run_program("nopreamble", program, &[]);
    assert_ne!(code, 0);
    assert!(err.contains("gripper_close"), "{err}");
    // A preamble that does not parse names its file, line and column.
    std::fs::write(&preamble, "x = 1\ndef broken(:\nend\n").unwrap();
    let (code, _, err) = run_program(
        "badpreamble",
        program,
        &["--preamble", preamble.to_str().unwrap()],
    );
    let _ = std::fs::remove_file(&preamble);
    assert_ne!(code, 0);
    assert!(
        err.contains("--preamble") && err.contains("line 2, column 12"),
        "{err}"
    );
}

#[test]
fn set_gives_the_inputs_the_program_reads() {
    let program = "if get_standard_digital_in(3):\n  textmsg(\"part present, force \", get_tcp_force()[2])\nend\n";
    let (code, out, err) = run_program(
        "set",
        program,
        &[
            "--set",
            "digital_in[3]=True",
            "--set",
            "tcp_force=[0, 0, -9.5, 0, 0, 0]",
        ],
    );
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(out.contains("part present, force -9.5"), "{out}");
    // The joints the arm starts at.
    let (code, out, err) = run_program(
        "setq",
        "textmsg(get_actual_joint_positions())\n",
        &["--set", "q=[0.5, -1.25, 1.5, -1.75, -1.5, 0]"],
    );
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(out.contains("[0.5, -1.25, 1.5, -1.75, -1.5, 0]"), "{out}");
    let (code, _, err) = run_program("badq", "x = 1\n", &["--set", "q[1]=9"]);
    assert_ne!(code, 0);
    assert!(err.contains("outside the joints' range"), "{err}");
    let (code, out, _) = run_program("unset", program, &[]);
    assert_eq!(code, 0);
    assert!(!out.contains("part present"), "{out}");
    let (code, _, err) = run_program("badset", program, &["--set", "digital_in[30]=True"]);
    assert_ne!(code, 0);
    assert!(
        err.contains("--set digital_in[30]=True: index 30 is past the last (17)"),
        "{err}"
    );
    let out = ursock()
        .args(["robot", "--set", "help"])
        .output()
        .expect("spawn ursock");
    let listed = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    assert!(
        listed.contains("digital_in") && listed.contains("operator_string"),
        "{listed}"
    );
}

#[test]
fn a_runtime_error_names_its_line_and_fails() {
    let (code, out, err) = run_program(
        "runtime",
        "def main():\n  values = [1, 2, 3]\n  textmsg(\"before\")\n  x = values[5]\n  textmsg(\"after\")\nend\n",
        &[],
    );
    assert_ne!(code, 0);
    assert!(out.contains("before") && !out.contains("after"), "{out}");
    assert!(err.contains("line 4:"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
}

#[test]
fn a_parse_error_names_line_and_column_and_nothing_is_sent() {
    let (l, port) = listener();
    l.set_nonblocking(true).unwrap();
    let program = format!(
        "socket_open(\"127.0.0.1\", {port})\nsocket_send_line(\"hello\")\nif x = = 3:\n  textmsg(1)\nend\n"
    );
    let (code, out, err) = run_program("parse", &program, &[]);
    assert_ne!(code, 0);
    assert!(err.contains("line 3, column"), "{err}");
    assert!(out.is_empty(), "{out}");
    assert!(
        l.accept().is_err(),
        "the program connected before its parse error"
    );
}

#[test]
fn one_call_per_line_scripts_still_run() {
    let (l, port) = listener();
    let server = thread::spawn(move || {
        let (mut s, _) = l.accept().unwrap();
        let line = read_until(&mut s, b'\n').unwrap();
        s.write_all(b"(1, 2)\n").unwrap();
        let _ = s.read(&mut [0u8; 16]);
        line
    });
    let addr = format!("127.0.0.1:{port}");
    let out = ursock()
        .args([
            "robot",
            "--connect",
            &addr,
            "-e",
            "socket_send_line(\"go\")",
            "-e",
            "x = socket_read_ascii_float(2)  # pose",
            "-e",
            "textmsg(x)",
        ])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(server.join().unwrap(), b"go");
    assert!(
        text.contains("x = socket_read_ascii_float(2) -> [2, 1, 2]"),
        "{text}"
    );
    assert!(text.contains("textmsg([2, 1, 2]) -> [2, 1, 2]"), "{text}");
}

#[test]
fn the_program_file_may_be_given_without_script() {
    let path =
        std::env::temp_dir().join(format!("ursock-positional-{}.script", std::process::id()));
    std::fs::write(&path, "textmsg(\"from a file\")\n").unwrap();
    let out = ursock()
        .args(["robot", path.to_str().unwrap()])
        .stdin(Stdio::null())
        .output()
        .expect("spawn ursock");
    let both = ursock()
        .args([
            "robot",
            path.to_str().unwrap(),
            "--script",
            path.to_str().unwrap(),
        ])
        .stdin(Stdio::null())
        .output()
        .expect("spawn ursock");
    let _ = std::fs::remove_file(&path);
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stdout).contains("from a file"));
    // One program: a file and --script together is a usage error.
    assert_eq!(both.status.code(), Some(2));
}
