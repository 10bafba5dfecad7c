//! Hostile programs (issue 18): nothing a program says may crash the interpreter (stack
//! overflow, allocator abort), stall it or make it grow without bound. Every test runs
//! in virtual time; those about recursion run on a thread with a small stack, so a
//! regression fails instead of passing by luck on a large main stack.
mod common;

use std::time::Duration;

use common::Harness;
use urscript_interp::{Config, Machine, Program, RuntimeErrorKind, State, MAX_VALUE_DEPTH};

/// A stack the bounded recursion fits in, far below what an unbounded one over these
/// inputs needs: 256 KiB in release builds; in debug builds (no inlining, every
/// temporary its own slot) the recursive-descent parser takes about 17 KiB of stack per
/// nesting level, so 64 levels need about 1.1 MiB there.
const STACK: usize = if cfg!(debug_assertions) {
    3 * 1024 * 1024
} else {
    256 * 1024
};

/// Runs `f` on a thread with a [`STACK`]-byte stack (a stack overflow aborts the test
/// binary: the test fails rather than passing by luck on a larger stack).
fn small_stack<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    std::thread::Builder::new()
        .stack_size(STACK)
        .spawn(f)
        .expect("spawn")
        .join()
        .expect("no panic")
}

/// The parse error of `src`, which must not parse.
fn parse_error(src: &str) -> urscript_interp::ParseError {
    match Program::parse(src) {
        Ok(_) => panic!("parsed: {}", &src[..src.len().min(80)]),
        Err(e) => e,
    }
}

/// Parses, compiles and runs `src` for `steps` steps; the machine's state.
fn run_steps(src: &str, config: Config, steps: u64) -> State {
    let program = Program::parse(src).unwrap_or_else(|e| panic!("parse: {e}"));
    let step = config.step_time;
    let mut m = Machine::new(program, config);
    for k in 0..steps {
        m.run_until(step * k as u32);
        while m.poll_event().is_some() {}
        if m.state() != &State::Running {
            break;
        }
        let (counted, recounted) = m.memory_audit();
        assert!(counted >= recounted, "memory count {counted} < {recounted}");
    }
    m.state().clone()
}

fn limit_error(state: State) -> String {
    match state {
        State::Error(e) if e.kind() == RuntimeErrorKind::Limit => e.to_string(),
        other => panic!("expected a Limit error, got {other:?}"),
    }
}

// ---------------------------------------------------------------------------------------
// 1. Expression depth

#[test]
fn long_operator_chains_are_a_parse_error_not_a_stack_overflow() {
    small_stack(|| {
        let chains = [
            format!("x = {}1", "1+".repeat(30_000)),
            format!("x = {}True", "True or ".repeat(30_000)),
            format!("x = {}1", "1 == ".repeat(30_000)),
            format!("x = {}1", "1 * ".repeat(30_000)),
            format!("x = [0]\ny = x{}", "[0]".repeat(100_000)),
            format!("x = {}1\n", "1 +\n".repeat(40_000)),
            format!("x = {}1", "+".repeat(100_000)),
            format!("x = {}1", "-".repeat(100_000)),
            format!("x = {}True", "not ".repeat(100_000)),
            format!("x = {}1{}", "(".repeat(100_000), ")".repeat(100_000)),
            format!("x = {}1{}", "[".repeat(100_000), "]".repeat(100_000)),
            format!("x = {}1{}", "f(".repeat(100_000), ")".repeat(100_000)),
            format!("x = {}1", "-x*".repeat(30_000)),
        ];
        for src in &chains {
            let e = parse_error(src);
            assert!(
                e.message().contains("nested too deeply"),
                "{}: {e}",
                &src[..40]
            );
            assert!(e
                .to_string()
                .starts_with(&format!("line {}, column ", e.line())));
        }
        // The chain's error points at the operator that passes the bound.
        let e = parse_error(&format!("x = {}1", "1+".repeat(200)));
        assert_eq!((e.line(), e.column()), (1, 4 + 2 * 128));
    });
}

#[test]
fn expressions_up_to_the_depth_bound_parse_compile_run_and_drop_on_a_small_stack() {
    small_stack(|| {
        // 127 additions: a tree 128 levels deep, the bound.
        let src = format!("x = {}1\ntextmsg(x)\n", "1+".repeat(127));
        assert_eq!(common::messages(&src), ["128"]);
        let e = parse_error(&format!("x = {}1\n", "1+".repeat(128)));
        assert!(e.message().contains("more than 128 levels"), "{e}");
        // Index chains, calls, lists and right-nested operators at the bound too.
        assert!(Program::parse(&format!("y = x{}\n", "[0]".repeat(127))).is_ok());
        assert!(Program::parse(&format!("y = x{}\n", "[0]".repeat(128))).is_err());
        let src = format!("x = {}\n", "1-(".repeat(60) + "1" + &")".repeat(60));
        assert!(matches!(
            run_steps(&src, Config::default(), 2),
            State::Finished
        ));
        let src = format!(
            "def f(a):\n  return a\nend\nx = {}1{}\n",
            "f(".repeat(60),
            ")".repeat(60)
        );
        assert!(matches!(
            run_steps(&src, Config::default(), 2),
            State::Finished
        ));
        let src = format!("x = {}True\n", "True and ".repeat(127));
        assert!(matches!(
            run_steps(&src, Config::default(), 2),
            State::Finished
        ));
    });
}

// ---------------------------------------------------------------------------------------
// 2. Value depth

#[test]
fn a_value_nested_past_the_bound_is_a_limit_error() {
    small_stack(|| {
        let inner = format!("{}x{}", "[".repeat(60), "]".repeat(60));
        let src = format!("x = 0\nwhile True:\n  x = {inner}\n  sync()\nend\n");
        let e = limit_error(run_steps(&src, Config::default(), 100_000));
        assert!(
            e.contains(&format!("more than {MAX_VALUE_DEPTH} levels")),
            "{e}"
        );
        // One level at a time, and through an element assignment.
        let src = "x = 0\nwhile True:\n  x = [x]\n  sync()\nend\n";
        let e = limit_error(run_steps(src, Config::default(), 100_000));
        assert!(e.starts_with("line 3: "), "{e}");
        let src = "x = [0]\nwhile True:\n  x[0] = [x, 1]\n  sync()\nend\n";
        let e = limit_error(run_steps(src, Config::default(), 100_000));
        assert!(e.starts_with("line 3: "), "{e}");
        let src = "x = [[0]]\nwhile True:\n  x[0][0] = x\n  sync()\nend\n";
        limit_error(run_steps(src, Config::default(), 100_000));
        // The deepest value allowed is built, compared, written and dropped.
        let src = format!(
            "x = 0\nn = 0\nwhile n < {MAX_VALUE_DEPTH}:\n  x = [x]\n  n = n + 1\nend\ny = x\nif x == y:\n  textmsg(x)\nend\n"
        );
        let expected = format!(
            "{}0{}",
            "[".repeat(MAX_VALUE_DEPTH),
            "]".repeat(MAX_VALUE_DEPTH)
        );
        assert_eq!(common::messages(&src), [expected]);
        // A parameter's default is held to the same bound.
        let deep = format!("{}0{}", "[".repeat(40), "]".repeat(40));
        let e = parse_error(&format!("def f(a={deep}):\n  return a\nend\nx = f()\n"));
        assert!(e.message().contains("over the value bounds"), "{e}");
    });
}

// ---------------------------------------------------------------------------------------
// 3. Value size

#[test]
fn a_doubling_list_is_a_limit_error_not_a_memory_bomb() {
    let src = "x = [1]\nwhile True:\n  x = [x, x]\n  sync()\nend\n";
    let e = limit_error(run_steps(src, Config::default(), 1_000));
    assert!(e.contains("more than 1000000 elements"), "{e}");
    // The bound is the configuration's.
    let config = Config {
        max_value_size: 100,
        ..Config::default()
    };
    let e = limit_error(run_steps(src, config.clone(), 1_000));
    assert!(e.contains("more than 100 elements"), "{e}");
    // Element assignment, list arithmetic and lists of strings count too.
    let src = "x = [0, 0]\nwhile True:\n  x[1] = [x, x]\n  sync()\nend\n";
    limit_error(run_steps(src, config.clone(), 1_000));
    let src = "x = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]\ny = [x, x, x, x, x, x, x, x, x, x]\n";
    limit_error(run_steps(src, config.clone(), 10));
    let s = "a".repeat(60);
    let src = format!("x = [\"{s}\", \"{s}\"]\n");
    limit_error(run_steps(&src, config.clone(), 10));
    // Under the bound, nothing changes.
    let src = "x = [1]\nn = 0\nwhile n < 4:\n  x = [x, x]\n  n = n + 1\nend\ntextmsg(\"ok\")\n";
    assert!(matches!(run_steps(src, config, 10), State::Finished));
}

// ---------------------------------------------------------------------------------------
// 4. Memory budget: every value, call depth and thread count within its own bound, but
// together more than the program may hold.

/// The attack found on the controller's port 30001: `threads` threads, each `depth` calls
/// deep with a list of `len` elements in every frame.
fn many_frames_holding_lists(threads: u32, depth: u32, len: u32) -> String {
    format!(
        "def attack():
  def deep(n):
    big = make_list({len}, 0)
    if n > 0:
      deep(n - 1)
    end
    sleep(100)
  end
  thread t():
    deep({depth})
  end
  i = 0
  while i < {threads}:
    run t()
    i = i + 1
  end
  sleep(100)
end
"
    )
}

fn budget_error(state: State) -> String {
    let e = limit_error(state);
    assert!(e.contains("memory budget exceeded"), "{e}");
    e
}

#[test]
fn frames_of_many_threads_holding_lists_are_a_budget_error() {
    // 8 threads 20 calls deep, 20 000 elements a frame: about 180 MB, each bound kept.
    let src = many_frames_holding_lists(8, 19, 20_000);
    let config = Config {
        max_memory: 8 << 20,
        ..Config::default()
    };
    let e = budget_error(run_steps(&src, config, 100));
    assert!(e.starts_with("line 3: "), "{e}");
    assert!(e.contains("over its budget of 8388608 bytes"), "{e}");
}

/// The attack at its real size with the default budget ends with the budget's error,
/// in a child process whose address space is capped at 2 GB (without the budget it
/// aborts there: allocation failure).
#[test]
fn the_attack_at_full_size_ends_with_the_budget_error_under_a_2_gb_cap() {
    const CHILD: &str = "URSCRIPT_INTERP_BUDGET_CHILD";
    if std::env::var_os(CHILD).is_some() {
        let src = many_frames_holding_lists(63, 249, 999_000);
        let e = budget_error(run_steps(&src, Config::default(), 1_000));
        assert!(e.contains("over its budget of 268435456 bytes"), "{e}");
        return;
    }
    let exe = std::env::current_exe().expect("test binary");
    let out = std::process::Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 2000000 && exec \"$0\" \"$@\"")
        .arg(exe)
        .args([
            "--exact",
            "the_attack_at_full_size_ends_with_the_budget_error_under_a_2_gb_cap",
            "--test-threads=1",
            "--nocapture",
        ])
        .env(CHILD, "1")
        .output()
        .expect("run sh");
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "child: {:?}\n{text}", out.status);
    assert!(text.contains("1 passed"), "{text}");
}

#[test]
fn one_operation_is_refused_before_it_allocates_past_the_budget() {
    let small = |bytes: usize| Config {
        max_memory: bytes,
        ..Config::default()
    };
    // make_list of long strings: a gigabyte asked for at once.
    let s = "a".repeat(1023);
    let src = format!("x = make_list(1000000, \"{s}\")\n");
    let e = budget_error(run_steps(&src, Config::default(), 10));
    assert!(e.starts_with("line 1: "), "{e}");
    // A list copied on assignment.
    let src = "x = make_list(20000, 0)\ny = x\n";
    let e = budget_error(run_steps(src, small(2 << 20), 10));
    assert!(e.starts_with("line 2: "), "{e}");
    // List arithmetic.
    let src = "x = make_list(20000, 1.0) * 2\n";
    let e = budget_error(run_steps(src, small(2 << 20), 10));
    assert!(e.starts_with("line 1: "), "{e}");
    // A matrix product far larger than its operands: 2000 x 1 times 1 x 2000.
    let src = "col = make_list(2000, 0)\ni = 0\nwhile i < 2000:\n  col[i] = [1.0]\n  i = i + 1\nend\nrow = [make_list(2000, 1.0)]\nm = col * row\n";
    let e = budget_error(run_steps(src, small(16 << 20), 10));
    assert!(e.starts_with("line 8: "), "{e}");
    // Messages the driver has not taken yet hold copies of their arguments.
    let src = "x = make_list(10000, 1.0)\ni = 0\nwhile i < 50:\n  textmsg(x)\n  i = i + 1\nend\n";
    let config = small(4 << 20);
    let mut m = Machine::new(Program::parse(src).unwrap(), config);
    m.run_until(Duration::ZERO);
    let e = budget_error(m.state().clone());
    assert!(e.starts_with("line 4: "), "{e}");
    // Taken as they come (a step each), they hold nothing.
    let src = "x = make_list(10000, 1.0)\ni = 0\nwhile i < 50:\n  textmsg(x)\n  sync()\n  i = i + 1\nend\n";
    let mut h = Harness::new(src, small(4 << 20));
    h.run_silent(Duration::from_secs(1));
    assert_eq!(h.m.state(), &State::Finished);
}

/// A program that makes and drops far more than its budget, in variables, list
/// elements, struct members, frames and threads, runs on; the count follows every drop
/// (it equals a recount after every step), so no step needs a recount.
#[test]
fn making_and_dropping_within_the_budget_runs_on_with_an_exact_count() {
    let src = "def f(n, a):
  local l = a + a
  if n > 0:
    return f(n - 1, l)
  end
  return length(l)
end
thread t():
  y = make_list(500, \"abc\")
  sleep(0.004)
end
k = 0
while k < 400:
  x = make_list(1000, 0)
  x[3] = [1, 2, \"ab\"]
  s = struct(a=x, b=[x[3], x[3]])
  s.b[0] = \"cd\"
  z = s.a
  n = f(3, [1.0, 2.0])
  h = run t()
  if k % 10 == 0:
    textmsg(str_cat(\"k \", k))
    sync()
  end
  k = k + 1
end
join h
textmsg(\"done \", n)
";
    // About 40 KB live; 400 rounds make and drop about 40 MB.
    let mut h = Harness::new(
        src,
        Config {
            max_memory: 1 << 20,
            ..Config::default()
        },
    );
    loop {
        h.now += h.step;
        h.m.run_until(h.now);
        while h.m.poll_event().is_some() {}
        if h.m.state() != &State::Running {
            break;
        }
        let (counted, recounted) = h.m.memory_audit();
        assert_eq!(counted, recounted, "at {:?}", h.now);
        assert!(h.now < Duration::from_secs(10), "still running");
    }
    assert_eq!(h.m.state(), &State::Finished);
}

// ---------------------------------------------------------------------------------------
// 7. Short-lived threads

#[test]
fn many_short_lived_threads_keep_running() {
    // 20 threads a step for 2 000 steps: 40 000 threads, each finished in its step.
    let src = "thread t():\n  y = 1\nend\nn = 0\nwhile n < 2000:\n  k = 0\n  while k < 20:\n    h = run t()\n    k = k + 1\n  end\n  n = n + 1\n  sync()\nend\ntextmsg(\"done \", h)\n";
    let mut h = Harness::new(src, Config::default());
    h.run_silent(Duration::from_secs(10));
    assert_eq!(h.m.state(), &State::Finished);
    assert_eq!(h.messages, ["done <thread 40000>"]);
}

#[test]
fn a_finished_threads_handle_never_names_a_new_thread() {
    let src = "thread quick():\n  y = 1\nend\nthread slow():\n  sleep(1)\n  textmsg(\"slow done\")\nend\na = run quick()\nsync()\nb = run slow()\nsync()\nif a == b:\n  textmsg(\"same handle\")\nend\njoin a\ntextmsg(\"joined a at once\")\nkill a\nsync()\njoin b\ntextmsg(\"after b\")\n";
    let mut h = Harness::new(src, Config::default());
    h.run_silent(Duration::from_secs(5));
    assert_eq!(h.m.state(), &State::Finished);
    assert_eq!(h.messages, ["joined a at once", "slow done", "after b"]);
}

// ---------------------------------------------------------------------------------------
// 10. Program text

#[test]
fn cr_only_line_ends_are_line_ends() {
    assert_eq!(
        common::messages("x = 1\ry = x + 1 # one more\rtextmsg(y)\r"),
        ["2"]
    );
    assert_eq!(
        common::messages("x = 1\r\ny = (x +\r 1)\rtextmsg(y)\r\n"),
        ["2"]
    );
    let e = parse_error("x = 1\ry = 2\rz = )\r");
    assert_eq!((e.line(), e.column()), (3, 5), "{e}");
    let e = parse_error("x = 1\ry = \"abc\rz = 1\r");
    assert_eq!((e.line(), e.column()), (2, 5), "{e}");
    // A backslash continuation before a lone CR.
    assert_eq!(common::messages("x = 1 + \\\r 2\rtextmsg(x)\r"), ["3"]);
}

#[test]
fn invalid_utf8_names_its_line_and_column() {
    let e = Program::parse_bytes(b"x = 1\ny = 2\nz = \"\xff\"\n").unwrap_err();
    assert_eq!((e.line(), e.column()), (3, 6), "{e}");
    assert!(e.message().contains("UTF-8"), "{e}");
    let mut bytes = "# é\rs = \"éé".as_bytes().to_vec();
    bytes.push(0x80);
    let e = Program::parse_bytes(&bytes).unwrap_err();
    assert_eq!((e.line(), e.column()), (2, 8), "{e}");
    let e = Program::parse_bytes(b"\xc3").unwrap_err();
    assert_eq!((e.line(), e.column()), (1, 1), "{e}");
    assert!(Program::parse_bytes("textmsg(\"é\")\n".as_bytes()).is_ok());
}

#[test]
fn columns_stay_right_on_long_lines() {
    // One long line of list items (with multi-byte characters), then an error at its end.
    let items = "\"é\", ".repeat(50_000);
    let src = format!("x = [{items}1] )\n");
    let e = parse_error(&src);
    let col = "x = [".chars().count() + items.chars().count() + "1] ".len() + 1;
    assert_eq!((e.line(), e.column() as usize), (1, col), "{e}");
    // The same after many lines and spaces.
    let src = format!("{}x = 1{} $\n", "\n".repeat(1000), " ".repeat(100_000));
    let e = parse_error(&src);
    assert_eq!((e.line(), e.column()), (1001, 100_007), "{e}");
}

#[test]
fn a_program_over_16_mib_is_refused_before_lexing() {
    let src = format!("x = 1\n{}", "#".repeat(16 * 1024 * 1024));
    let e = parse_error(&src);
    assert_eq!((e.line(), e.column()), (1, 1));
    assert!(e.message().contains("program too large"), "{e}");
    let e = Program::parse_bytes(src.as_bytes()).unwrap_err();
    assert!(e.message().contains("program too large"), "{e}");
    // Just under the bound is fine.
    let src = format!("x = 1\n#{}", "#".repeat(16 * 1024 * 1024 - 8));
    assert!(Program::parse(&src).is_ok());
}

#[test]
fn many_distinct_names_compile() {
    let src: String = (0..20_000).map(|i| format!("f{i}()\n")).collect();
    let p = Program::parse(&src).expect("parses");
    assert_eq!(p.called_builtins().len(), 20_000);
    assert_eq!(p.called_builtins()[19_999], "f19999");
}

// ---------------------------------------------------------------------------------------
// The fuzz target's seeds (fuzz/seeds/interp, and every input it ever found) replay here,
// driven as fuzz/fuzz_targets/interp.rs drives them, so `cargo test` covers them.

#[test]
fn fuzz_seeds_replay() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../fuzz/seeds/interp");
    let Ok(entries) = std::fs::read_dir(dir) else {
        return; // a packaged crate has no fuzz/
    };
    for entry in entries {
        let path = entry.expect("entry").path();
        let data = std::fs::read(&path).expect("seed");
        let (text, mut feed) = match data.iter().position(|&b| b == 0) {
            Some(i) => (&data[..i], &data[i + 1..]),
            None => (&data[..], &[][..]),
        };
        let Ok(program) = Program::parse_bytes(text) else {
            continue;
        };
        let config = Config {
            max_statements_per_step: 1_000,
            max_value_size: 1_000,
            max_memory: 1 << 20,
            trace_all_calls: true,
            ..Config::default()
        };
        let step = config.step_time;
        let mut m = Machine::new(program, config);
        let mut chunk = || {
            let Some((&n, rest)) = feed.split_first() else {
                return Vec::new();
            };
            let n = usize::from(n % 32).min(rest.len());
            feed = &rest[n..];
            rest[..n].to_vec()
        };
        for k in 0..100u32 {
            for name in m.open_sockets() {
                m.handle_received(&name, &chunk());
            }
            m.run_until(step * k);
            while let Some(e) = m.poll_event() {
                match e {
                    urscript_interp::Event::Connect {
                        socket_name, port, ..
                    } => {
                        let r = if port % 10 == 7 {
                            Err("refused".to_string())
                        } else {
                            Ok(())
                        };
                        m.handle_connected(&socket_name, r);
                    }
                    urscript_interp::Event::Transmit { socket_name, .. } => {
                        m.handle_received(&socket_name, &chunk());
                    }
                    _ => {}
                }
            }
            if m.state() != &State::Running {
                break;
            }
            let (counted, recounted) = m.memory_audit();
            assert!(
                counted >= recounted,
                "{}: {counted} < {recounted}",
                path.display()
            );
        }
    }
}

// ---------------------------------------------------------------------------------------
// Sockets

#[test]
fn opening_sockets_under_new_names_without_end_is_a_limit_error() {
    use urscript_interp::builtins::sockets::MAX_SOCKETS;
    let src = "i = 0\nwhile True:\n  socket_open(\"127.0.0.1\", 5000, str_cat(\"s\", i))\n  i = i + 1\nend\n";
    let config = Config::default();
    let step = config.step_time;
    let mut m = Machine::new(Program::parse(src).unwrap(), config);
    let mut connected = 0usize;
    // Every connect succeeds (the test is the driver): the bound, not the network, ends it.
    for k in 0..10 * MAX_SOCKETS as u32 {
        m.run_until(step * k);
        while let Some(e) = m.poll_event() {
            if let urscript_interp::Event::Connect { socket_name, .. } = e {
                m.handle_connected(&socket_name, Ok(()));
                connected += 1;
            }
        }
        if m.state() != &State::Running {
            break;
        }
    }
    let e = limit_error(m.state().clone());
    assert!(e.contains("sockets are open already"), "{e}");
    assert_eq!(connected, MAX_SOCKETS);
    // Reopening an open name, or opening after a close, stays within it.
    let src = "i = 0\nwhile i < 200:\n  socket_open(\"127.0.0.1\", 5000, str_cat(\"s\", i % 8))\n  socket_close(str_cat(\"s\", (i + 4) % 8))\n  i = i + 1\nend\n";
    let mut m = Machine::new(Program::parse(src).unwrap(), Config::default());
    for k in 0..2_000u32 {
        m.run_until(step * k);
        while let Some(e) = m.poll_event() {
            if let urscript_interp::Event::Connect { socket_name, .. } = e {
                m.handle_connected(&socket_name, Ok(()));
            }
        }
        if m.state() != &State::Running {
            break;
        }
    }
    assert_eq!(m.state(), &State::Finished);
}
