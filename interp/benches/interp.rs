//! Interpreter speed: statements per second, and one 2 ms step of an
//! External-Control-like servo loop (one reverse message in, one servoj out).
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use urscript_interp::{Config, Machine, Program, State};

fn int32s(v: &[i32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_be_bytes()).collect()
}

/// 10 statements per iteration (the `while` condition counts as its own), 1000
/// iterations per step.
const LOOP: &str = "i = 0
total = 0.0
q = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]
while True:
  j = 0
  while j < 1000:
    x = q[j % 6] * 2.0 + 1
    if x > 1.5 and j != 3:
      total = total + x / 1000000
    else:
      total = total - 1
    end
    q[0] = total
    j = j + 1
    i = i + 1
  end
  sync()
end
";

fn statements(c: &mut Criterion) {
    let program = Program::parse(LOOP).unwrap();
    let mut g = c.benchmark_group("interp");
    // Per step: 1000 iterations x (while test, x =, if, total =, q[0] =, j =, i =) = 7000
    // statements counted by the machine's `Stmt` marks, plus the loop's own jump.
    g.throughput(Throughput::Elements(7000));
    let mut m = Machine::new(program, Config::default());
    let mut now = Duration::ZERO;
    m.run_until(now);
    g.bench_function("statements_per_step_7000", |b| {
        b.iter(|| {
            now += Duration::from_millis(2);
            m.run_until(now);
        })
    });
    assert_eq!(m.state(), &State::Running);
    g.finish();
}

fn servo_step(c: &mut Criterion) {
    servo_step_with(c, true);
    servo_step_with(c, false);
}

fn servo_step_with(c: &mut Criterion, trace: bool) {
    let src = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/programs/external_control_like.script"
    ))
    .unwrap();
    let config = Config {
        trace_socket_calls: trace,
        ..Config::default()
    };
    let mut m = Machine::new(Program::parse(&src).unwrap(), config);
    let mut now = Duration::ZERO;
    // Connect the three sockets.
    for _ in 0..4 {
        m.run_until(now);
        while let Some(e) = m.poll_event() {
            if let urscript_interp::Event::Connect { socket_name, .. } = e {
                m.handle_connected(&socket_name, Ok(()));
            }
        }
        now += Duration::from_millis(2);
    }
    let mut i: i32 = 0;
    let mut g = c.benchmark_group("interp");
    g.throughput(Throughput::Elements(1));
    let name = if trace {
        "external_control_servo_step_2ms_traced"
    } else {
        "external_control_servo_step_2ms_untraced"
    };
    g.bench_function(name, |b| {
        b.iter(|| {
            i = i.wrapping_add(1);
            let q = i % 1000 * 1000;
            let msg = int32s(&[20, q, -1_570_000, 1_570_000, -1_570_000, -1_570_000, 0, 1]);
            m.handle_received("reverse_socket", &msg);
            m.run_until(now);
            while m.poll_event().is_some() {}
            now += Duration::from_millis(2);
        })
    });
    assert_eq!(m.state(), &State::Running);
    g.finish();
}

/// The arm model behind `get_jacobian`, `get_mass_matrix` and
/// `get_coriolis_and_centrifugal_torques`, called as a 500 Hz control loop would (UR's
/// joint impedance example calls all of them every step).
fn arm_model(c: &mut Criterion) {
    use urscript_interp::kinematics::dynamics::{self, Payload};
    use urscript_interp::kinematics::{jacobian, jacobian_time_derivative, Model};
    let q = [0.3, -1.1, 1.4, -0.7, 1.2, 0.5];
    let qd = [0.4, -0.3, 0.8, 0.5, -0.6, 0.9];
    let dh = Model::Ur5e.dh();
    c.bench_function("get_jacobian_ur5e", |b| {
        b.iter(|| jacobian(&dh, std::hint::black_box(q), [0.0; 6]))
    });
    c.bench_function("get_jacobian_time_derivative_ur5e", |b| {
        b.iter(|| jacobian_time_derivative(&dh, std::hint::black_box(q), qd, [0.0; 6]))
    });
    c.bench_function("get_mass_matrix_ur5e", |b| {
        b.iter(|| dynamics::mass_matrix(Model::Ur5e, std::hint::black_box(q), &Payload::NONE))
    });
    c.bench_function("get_coriolis_and_centrifugal_torques_ur5e", |b| {
        b.iter(|| {
            dynamics::coriolis_and_centrifugal_torques(
                Model::Ur5e,
                std::hint::black_box(q),
                qd,
                &Payload::NONE,
            )
        })
    });
}

/// Interpreter mode: 100 statement lines compiled into the running program
/// (`Machine::interpreter_line`), run (one a step), then `clear_interpreter()`, as UR's
/// example client clears after a batch.
fn interpreter_lines(c: &mut Criterion) {
    const LINES: usize = 100;
    let program = Program::parse("total = 0\ninterpreter_mode()\n").unwrap();
    let mut m = Machine::new(program, Config::default());
    let mut now = Duration::ZERO;
    m.run_until(now);
    let lines: Vec<String> = (0..LINES)
        .map(|k| format!("total = total + {k} q = [total, {k}, 0.5]"))
        .collect();
    let mut g = c.benchmark_group("interp");
    g.throughput(Throughput::Elements(LINES as u64));
    g.bench_function("interpreter_mode_100_lines_run_and_cleared", |b| {
        b.iter(|| {
            for line in &lines {
                let _ = m.interpreter_line(line.as_bytes());
            }
            let _ = m.interpreter_line(b"clear_interpreter()");
            now += Duration::from_millis(2) * (LINES as u32 + 3);
            m.run_until(now);
        })
    });
    assert_eq!(m.state(), &State::Running);
    assert_eq!(m.interpreter_status().unexecuted, 0);
    g.finish();
}

criterion_group!(
    benches,
    statements,
    servo_step,
    arm_model,
    interpreter_lines
);
criterion_main!(benches);
