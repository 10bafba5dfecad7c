//! Motion and output events: a move's start and end, streams summarised, output changes.

use std::time::Duration;

use urscript_interp::{
    Config, Event, Machine, MoveEnd, MoveOutcome, MoveStart, OutputValue, Program, State,
};

fn run(src: &str) -> (Machine, Vec<Event>) {
    let mut m = Machine::new(Program::parse(src).unwrap(), Config::default());
    m.run_until(Duration::from_secs(120));
    let mut events = Vec::new();
    while let Some(e) = m.poll_event() {
        events.push(e);
    }
    (m, events)
}

fn starts(events: &[Event]) -> Vec<&MoveStart> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::MoveStart(s) => Some(&**s),
            _ => None,
        })
        .collect()
}

fn ends(events: &[Event]) -> Vec<&MoveEnd> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::MoveEnd(s) => Some(&**s),
            _ => None,
        })
        .collect()
}

fn close(a: [f64; 6], b: [f64; 6]) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6)
}

#[test]
fn a_move_is_reported_with_its_target_and_how_it_ended() {
    let (m, ev) = run("movej([0.5, -1.5, 1, -1, 0.2, 0], a=1.4, v=1.05)\nmovel(p[0.3, -0.2, 0.4, 0, 3.1, 0], a=1.2, v=0.25, r=0)\n");
    assert_eq!(*m.state(), State::Finished);
    let (s, e) = (starts(&ev), ends(&ev));
    assert_eq!(s.len(), 2, "{ev:?}");
    assert_eq!(e.len(), 2, "{ev:?}");
    assert_eq!((s[0].function, s[0].line), ("movej", 1));
    assert!(close(
        s[0].target_q.unwrap(),
        [0.5, -1.5, 1.0, -1.0, 0.2, 0.0]
    ));
    assert_eq!((s[0].a, s[0].v, s[0].r), (1.4, 1.05, 0.0));
    assert_eq!(e[0].outcome, MoveOutcome::Reached);
    assert!(close(e[0].q, [0.5, -1.5, 1.0, -1.0, 0.2, 0.0]));
    assert!(e[0].took > Duration::from_millis(500), "{:?}", e[0].took);
    // The second starts where and when the first ended.
    assert_eq!(s[1].at, e[0].at);
    assert_eq!(s[1].function, "movel");
    assert_eq!(s[1].target_pose, Some([0.3, -0.2, 0.4, 0.0, 3.1, 0.0]));
    assert_eq!(e[1].outcome, MoveOutcome::Reached);
    assert!(close(e[1].pose, [0.3, -0.2, 0.4, 0.0, 3.1, 0.0]));
    assert_eq!(e[1].took, e[1].at - s[1].at);
    assert_eq!(e[1].samples, 1);
}

#[test]
fn a_blended_move_ends_blended_and_the_next_takes_over() {
    let (_, ev) =
        run("movej([0.5, -1.5, 1, -1, 0.2, 0], r=0.05)\nmovej([1, -1.5, 1, -1, 0.2, 0])\n");
    let e = ends(&ev);
    assert_eq!(e.len(), 2, "{ev:?}");
    assert_eq!(e[0].outcome, MoveOutcome::Blended);
    assert_eq!(e[1].outcome, MoveOutcome::Reached);
    assert_eq!(starts(&ev)[1].at, e[0].at);
}

#[test]
fn a_move_after_a_blend_began_starts_when_the_first_ends() {
    let (_, ev) = run(
        "movej([0.5, -1.5, 1, -1, 0.2, 0], r=0.05)\nsleep(0.01)\nmovej([1, -1.5, 1, -1, 0.2, 0])\n",
    );
    let (s, e) = (starts(&ev), ends(&ev));
    assert_eq!((s.len(), e.len()), (2, 2), "{ev:?}");
    assert_eq!(e[0].outcome, MoveOutcome::Reached);
    assert!(
        close(e[0].q, [0.5, -1.5, 1.0, -1.0, 0.2, 0.0]),
        "{:?}",
        e[0].q
    );
    assert_eq!(s[1].at, e[0].at);
    assert_eq!(e[1].outcome, MoveOutcome::Reached);
}

#[test]
fn a_servo_stream_is_one_start_and_one_end_with_its_sample_count() {
    let src = "q = get_actual_joint_positions()\ni = 0\nwhile i < 250:\n  q[0] = q[0] + 0.001\n  servoj(q, t=0.008)\n  i = i + 1\nend\n";
    let (_, ev) = run(src);
    let (s, e) = (starts(&ev), ends(&ev));
    assert_eq!((s.len(), e.len()), (1, 1), "{ev:?}");
    assert_eq!(s[0].function, "servoj");
    assert_eq!(e[0].samples, 250);
    assert_eq!(e[0].outcome, MoveOutcome::Reached);
    assert_eq!(e[0].took, Duration::from_secs(2));
    assert!((e[0].q[0] - 0.25).abs() < 1e-6, "{:?}", e[0].q);
}

#[test]
fn a_speed_stream_stopped_by_stopj_ends_stopped() {
    let (_, ev) = run("speedj([0.2, 0, 0, 0, 0, 0], a=1.0, t=0.5)\nspeedj([0.3, 0, 0, 0, 0, 0], a=1.0, t=0.5)\nstopj(2)\n");
    let (s, e) = (starts(&ev), ends(&ev));
    assert_eq!((s.len(), e.len()), (1, 1), "{ev:?}");
    assert_eq!(s[0].speed, Some([0.2, 0.0, 0.0, 0.0, 0.0, 0.0]));
    assert_eq!(e[0].outcome, MoveOutcome::Stopped);
    assert_eq!(e[0].samples, 2);
    assert_eq!(e[0].took, Duration::from_secs(1));
}

#[test]
fn a_protective_stop_ends_the_move_under_way() {
    let src = "thread t():\n  movej([2, -1.5, 1, -1, 0.2, 0], a=0.5, v=0.5)\nend\nh = run t()\nsleep(0.5)\nprotective_stop()\n";
    let (_, ev) = run(src);
    let e = ends(&ev);
    assert_eq!(e.len(), 1, "{ev:?}");
    assert_eq!(e[0].outcome, MoveOutcome::ProtectiveStop);
    assert_eq!(e[0].took, Duration::from_millis(500));
}

#[test]
fn a_move_the_program_ends_under_is_halted() {
    let src = "thread t():\n  movej([2, -1.5, 1, -1, 0.2, 0], a=0.5, v=0.5)\nend\nh = run t()\nsleep(0.3)\nhalt\n";
    let (_, ev) = run(src);
    let e = ends(&ev);
    assert_eq!(e.len(), 1, "{ev:?}");
    assert_eq!(e[0].outcome, MoveOutcome::Halted);
}

#[test]
fn output_changes_are_reported_once_each() {
    let src = "set_standard_digital_out(1, True)\nset_standard_digital_out(1, True)\nset_tool_digital_out(0, True)\nset_standard_analog_out(0, 0.5)\nset_standard_digital_out(1, False)\n";
    let (_, ev) = run(src);
    let out: Vec<_> = ev
        .iter()
        .filter_map(|e| match e {
            Event::Output(o) => Some((o.line, o.function, o.pin, o.value)),
            _ => None,
        })
        .collect();
    assert_eq!(
        out,
        [
            (1, "set_standard_digital_out", 1, OutputValue::Digital(true)),
            (3, "set_tool_digital_out", 0, OutputValue::Digital(true)),
            (4, "set_standard_analog_out", 0, OutputValue::Analog(0.5)),
            (
                5,
                "set_standard_digital_out",
                1,
                OutputValue::Digital(false)
            ),
        ]
    );
}
