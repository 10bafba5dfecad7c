#![no_main]
//! The virtual controller's client-facing state machines on hostile input (the
//! mission's "hostile peers never crash, hang or grow it"): one controller, one cell,
//! a dashboard client, a primary-port client (script intake) and an RTDE client, fed an
//! arbitrary interleaving of lines, bytes and time steps; and `.urp` programs read and
//! translated: arbitrary bytes (as given, or gzip-compressed first), and documents
//! built from fuzz-chosen program nodes (nesting, references to enclosing nodes and
//! siblings, External Control nodes), each External Control fetch answered with a
//! fuzz-chosen reply (text repeated up to 1 MiB, or a failure). Nothing may panic;
//! what the controller holds for a client stays within its documented bounds; a
//! translation stays within `MAX_SCRIPT_BYTES` and fetches at most once. Run it under a
//! memory cap (`-rss_limit_mb=1024`): the translation's bounds must hold it there.
use std::time::Duration;

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use std::io::Write;
use urscript_controller::script_intake::{Intake, ScriptIntake};

use urscript_controller::urp::MAX_SCRIPT_BYTES;
use urscript_controller::{
    read_external_control_settings, read_urp, translate_with, Cell, Config, Controller, Dashboard,
    FetchError, InputRegistry, RtdeSession, Submitted, RTDE_MAX_OUTBOX,
};

#[derive(Arbitrary, Debug)]
enum Action<'a> {
    /// One line to the dashboard server.
    Dashboard(&'a str),
    /// Bytes on the primary port (programs, bare lines, commands).
    Primary(&'a [u8]),
    /// Bytes from an RTDE client.
    Rtde(&'a [u8]),
    /// Time passes (milliseconds).
    Advance(u8),
    /// A `.urp` file's bytes, read and translated (also as an installation).
    Urp(&'a [u8], Reply<'a>),
    /// The same bytes gzip-compressed first, as PolyScope saves a `.urp`.
    UrpGzip(&'a [u8], Reply<'a>),
    /// A program built from nodes, plain or gzip-compressed.
    UrpBuilt(Vec<Node<'a>>, Reply<'a>, bool),
}

/// What the External Control URCap's host answers.
#[derive(Arbitrary, Debug)]
enum Reply<'a> {
    /// `text` repeated `times` times (at most 1 MiB in all).
    Script(&'a str, u16),
    Timeout,
    Connect(&'a str),
    TooLarge,
}

/// A piece of a built program's `<children>`.
#[derive(Arbitrary, Debug)]
enum Node<'a> {
    ExternalControl,
    /// An External Control node with a host and port in its data model.
    ExternalControlAt(&'a str, &'a str),
    ScriptLine(&'a str),
    /// `Script type="File"` with cached contents.
    ScriptFile(&'a str),
    Comment(&'a str),
    /// Opens a `Folder`, a `Loop type="Forever"` or a `Move` (closed by `Close` or at
    /// the end).
    Open(u8),
    Close,
    /// A node referring `up` levels up (an enclosing node: a cycle).
    RefUp(u8),
    /// A reference to the k-th `Script` sibling.
    RefScript(u8),
    Raw(&'a str),
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A `.urp` document holding `nodes` in its main program.
fn build(nodes: &[Node<'_>]) -> String {
    const EC: &str = r#"<Contributed strategyClass="com.fzi.externalcontrol.ExternalControlNode" strategyProgramNodeType="External Control">"#;
    let mut xml = String::from(
        r#"<URProgram name="fuzz" installation="default"><children><MainProgram runOnlyOnce="true"><children>"#,
    );
    let mut open: Vec<&str> = Vec::new();
    for node in nodes {
        match node {
            Node::ExternalControl => {
                xml.push_str(EC);
                xml.push_str("<dataModel/></Contributed>");
            }
            Node::ExternalControlAt(host, port) => {
                xml.push_str(EC);
                xml.push_str(&format!(
                    r#"<dataModel><entry key="host_ip" value="{}"/><entry key="port_nr" value="{}"/></dataModel></Contributed>"#,
                    escape(host),
                    escape(port)
                ));
            }
            Node::ScriptLine(text) => xml.push_str(&format!(
                r#"<Script type="Line"><expression>{}</expression></Script>"#,
                escape(text)
            )),
            Node::ScriptFile(text) => xml.push_str(&format!(
                r#"<Script type="File"><cachedContents>{}</cachedContents></Script>"#,
                escape(text)
            )),
            Node::Comment(text) => {
                xml.push_str(&format!(r#"<Comment comment="{}"/>"#, escape(text)))
            }
            Node::Open(kind) => {
                let (head, tail) = match kind % 3 {
                    0 => ("<Folder><children>", "</children></Folder>"),
                    1 => (r#"<Loop type="Forever"><children>"#, "</children></Loop>"),
                    _ => (
                        r#"<Move motionType="MoveJ"><children>"#,
                        "</children></Move>",
                    ),
                };
                xml.push_str(head);
                open.push(tail);
            }
            Node::Close => {
                if let Some(tail) = open.pop() {
                    xml.push_str(tail);
                }
            }
            Node::RefUp(up) => {
                let path = vec![".."; 2 * (usize::from(*up) % 8 + 1)].join("/");
                xml.push_str(&format!(r#"<Folder reference="{path}"/>"#));
            }
            Node::RefScript(k) => xml.push_str(&format!(
                r#"<Script reference="../Script[{}]"/>"#,
                k % 8 + 1
            )),
            Node::Raw(text) => xml.push_str(text),
        }
    }
    while let Some(tail) = open.pop() {
        xml.push_str(tail);
    }
    xml.push_str("</children></MainProgram></children></URProgram>");
    xml
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    let _ = gz.write_all(bytes);
    gz.finish().unwrap_or_default()
}

/// Reads and translates `bytes`, the fetch answered with `reply`.
fn translate(bytes: &[u8], reply: &Reply<'_>) {
    let _ = read_external_control_settings(bytes);
    let Ok(program) = read_urp(bytes) else { return };
    assert!(program.script.len() <= MAX_SCRIPT_BYTES);
    let mut fetches = 0;
    let translated = translate_with(&program, |_| {
        fetches += 1;
        match reply {
            Reply::Script(text, times) => {
                let times = usize::from(*times).min((1 << 20) / text.len().max(1));
                Ok(text.repeat(times))
            }
            Reply::Timeout => Err(FetchError::Timeout),
            Reply::Connect(why) => Err(FetchError::Connect(why.to_string())),
            Reply::TooLarge => Err(FetchError::TooLarge { limit: 1 << 20 }),
        }
    });
    assert!(fetches <= 1, "{fetches} fetches");
    if let Ok(script) = translated {
        assert!(script.len() <= MAX_SCRIPT_BYTES, "{}", script.len());
    }
}

/// Most actions per input.
const MAX_ACTIONS: usize = 64;

fuzz_target!(|actions: Vec<Action<'_>>| {
    let config = Config::default();
    let controller = Controller::new(config.clone());
    let mut interp = Cell::interp_config(&controller);
    interp.max_statements_per_step = 1_000;
    interp.max_value_size = 1_000;
    let mut cell = Cell::new(controller, interp);
    let mut dashboard = Dashboard::new();
    let mut intake = ScriptIntake::new();
    let mut registry = InputRegistry::new();
    let mut rtde = RtdeSession::new(&config, &mut registry);
    let mut now = Duration::ZERO;
    for action in actions.into_iter().take(MAX_ACTIONS) {
        match action {
            Action::Dashboard(line) => {
                let reply = dashboard.handle_line(cell.controller(), line, now);
                assert!(reply.to_bytes().len() < 1 << 20);
            }
            Action::Primary(bytes) => {
                for item in intake.push(bytes) {
                    match item {
                        Ok(Intake::Program { source, .. }) => {
                            cell.submit(Submitted::Program(source), now)
                        }
                        Ok(Intake::Secondary { source, .. }) => {
                            cell.submit(Submitted::Secondary(source), now)
                        }
                        Ok(Intake::Line(line)) => cell.submit(Submitted::Program(line), now),
                        Ok(Intake::Command(_)) | Err(_) => {}
                    }
                }
            }
            Action::Rtde(bytes) => {
                if rtde.handle_received(&mut registry, bytes).is_err() {
                    rtde.close(&mut registry);
                    rtde = RtdeSession::new(&config, &mut registry);
                }
            }
            Action::Advance(ms) => {
                // Step by step, as the real-time loop does.
                let end = now + Duration::from_millis(u64::from(ms));
                while now < end {
                    now += cell.step_time();
                    cell.advance(now);
                    let status = cell.status();
                    rtde.on_step(&status, now);
                    let _ = rtde.take_outbox();
                    while rtde.poll_event().is_some() {}
                }
            }
            Action::Urp(bytes, reply) => translate(bytes, &reply),
            Action::UrpGzip(bytes, reply) => translate(&gzip(bytes), &reply),
            Action::UrpBuilt(nodes, reply, compressed) => {
                let xml = build(&nodes);
                if compressed {
                    translate(&gzip(xml.as_bytes()), &reply);
                } else {
                    translate(xml.as_bytes(), &reply);
                }
            }
        }
        while cell.poll_event().is_some() {}
        // The RTDE client's replies are bounded even when nobody takes them.
        assert!(
            rtde.outbox().len() <= RTDE_MAX_OUTBOX,
            "{}",
            rtde.outbox().len()
        );
    }
});
