//! A fake in-memory peer driving a machine through its sans-IO events, in virtual time.
#![allow(dead_code)]

use std::collections::HashMap;
use std::time::Duration;

use urscript_interp::{Config, Event, Machine, MessageKind, Program, State};

/// What the fake server sees.
pub enum Input<'a> {
    /// A socket connected to this port.
    Connected(&'a str, u16),
    /// The program sent these bytes.
    Received(&'a str, &'a [u8]),
    /// A step begins at this time (send unsolicited data here).
    Tick(Duration),
}

pub struct Harness {
    pub m: Machine,
    pub now: Duration,
    pub step: Duration,
    pub sent: HashMap<String, Vec<u8>>,
    pub messages: Vec<String>,
    pub calls: Vec<String>,
    pub connects: Vec<(String, String, u16)>,
    pub closed: Vec<String>,
    /// Ports whose connection is refused.
    pub refuse: Vec<u16>,
}

impl Harness {
    pub fn new(src: &str, config: Config) -> Self {
        let program = Program::parse(src).unwrap_or_else(|e| panic!("parse: {e}"));
        let step = config.step_time;
        Harness {
            m: Machine::new(program, config),
            now: Duration::ZERO,
            step,
            sent: HashMap::new(),
            messages: Vec::new(),
            calls: Vec::new(),
            connects: Vec::new(),
            closed: Vec::new(),
            refuse: Vec::new(),
        }
    }

    pub fn program(path: &str, config: Config) -> Self {
        let src = std::fs::read_to_string(format!(
            "{}/tests/programs/{path}",
            env!("CARGO_MANIFEST_DIR")
        ))
        .expect("program file");
        Self::new(&src, config)
    }

    /// Runs until the program stops or `limit` of virtual time passed; `server` answers.
    pub fn run(
        &mut self,
        limit: Duration,
        mut server: impl FnMut(Input<'_>) -> Vec<(String, Vec<u8>)>,
    ) -> &State {
        loop {
            for (name, bytes) in server(Input::Tick(self.now)) {
                self.m.handle_received(&name, &bytes);
            }
            self.m.run_until(self.now);
            self.audit_memory();
            while let Some(e) = self.m.poll_event() {
                let replies = match e {
                    Event::Connect {
                        socket_name,
                        host,
                        port,
                    } => {
                        self.connects.push((socket_name.clone(), host, port));
                        if self.refuse.contains(&port) {
                            self.m.handle_connected(&socket_name, Err("refused".into()));
                            Vec::new()
                        } else {
                            self.m.handle_connected(&socket_name, Ok(()));
                            server(Input::Connected(&socket_name, port))
                        }
                    }
                    Event::Transmit { socket_name, bytes } => {
                        self.sent
                            .entry(socket_name.clone())
                            .or_default()
                            .extend_from_slice(&bytes);
                        server(Input::Received(&socket_name, &bytes))
                    }
                    Event::Close { socket_name } => {
                        self.closed.push(socket_name);
                        Vec::new()
                    }
                    Event::Message(m) => {
                        // Popups as `popup "Title": text`, the log lines as their text.
                        self.messages.push(match m.kind {
                            MessageKind::Popup { title, .. } => {
                                format!("popup \"{title}\": {}", m.text)
                            }
                            _ => m.text,
                        });
                        Vec::new()
                    }
                    Event::Call(c) => {
                        self.calls.push(format!("{}: {c}", c.line));
                        Vec::new()
                    }
                    Event::MoveStart(_) | Event::MoveEnd(_) | Event::Output(_) => Vec::new(),
                };
                for (name, bytes) in replies {
                    self.m.handle_received(&name, &bytes);
                }
            }
            if self.m.state() != &State::Running || self.now >= limit {
                return self.m.state();
            }
            self.now += self.step;
        }
    }

    /// The machine's count of the program's memory is never below what it holds (a
    /// recount): the budget can only err on the safe side. Checked after every step of
    /// every program the harness runs.
    pub fn audit_memory(&mut self) {
        if self.m.state() != &State::Running {
            return;
        }
        let (counted, recounted) = self.m.memory_audit();
        if std::env::var_os("AUDIT_DEBUG").is_some() && counted != recounted {
            eprintln!("memory audit: counted {counted}, recounted {recounted}");
        }
        assert!(
            counted >= recounted,
            "memory count {counted} below the {recounted} bytes the program holds"
        );
    }

    /// Runs with no server answering.
    pub fn run_silent(&mut self, limit: Duration) -> &State {
        self.run(limit, |_| Vec::new())
    }

    pub fn sent(&self, name: &str) -> &[u8] {
        self.sent.get(name).map_or(&[], Vec::as_slice)
    }
}

/// Runs a program with no sockets for `limit` and returns the harness.
pub fn run(src: &str) -> Harness {
    let mut h = Harness::new(src, Config::default());
    h.run_silent(Duration::from_secs(5));
    h
}

/// The messages of a program that must finish.
pub fn messages(src: &str) -> Vec<String> {
    let h = run(src);
    assert_eq!(
        h.m.state(),
        &State::Finished,
        "messages so far: {:?}",
        h.messages
    );
    h.messages
}

/// The runtime error of a program that must fail.
pub fn runtime_error(src: &str) -> String {
    let h = run(src);
    match h.m.state() {
        State::Error(e) => e.to_string(),
        other => panic!("expected a runtime error, got {other:?}"),
    }
}

pub fn int32s(v: &[i32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_be_bytes()).collect()
}
