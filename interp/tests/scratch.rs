use std::time::Duration;
use urscript_interp::*;

fn run(src: &str) -> (Machine, Vec<Event>) {
    let p = Program::parse(src).unwrap_or_else(|e| panic!("{e}"));
    let mut m = Machine::new(p, Config::default());
    m.run_until(Duration::from_secs(1));
    let ev = std::iter::from_fn(|| m.poll_event()).collect();
    (m, ev)
}

#[test]
fn basics() {
    let (m, ev) = run("def f(a, b=2):\n  return a * b\nend\nx = f(3)\ny = f(3, b=4)\nl = [1, 2.5, True]\nl[0] = 7\nq = p[1, 2, 3, 0, 0, 0]\nq[2] = 9\ntextmsg(x, y)\ntextmsg(l)\ntextmsg(q)\n");
    println!("{:?} {ev:?}", m.state());
    assert_eq!(m.state(), &State::Finished);
}
