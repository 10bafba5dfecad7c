#![no_main]
//! The virtual controller's client-facing state machines on hostile input (the
//! mission's "hostile peers never crash, hang or grow it"): one controller, one cell,
//! a dashboard client, a primary-port client (script intake) and an RTDE client, fed an
//! arbitrary interleaving of lines, bytes and time steps; and `.urp` bytes read and
//! translated. Nothing may panic; what the controller holds for a client stays within
//! its documented bounds.
use std::time::Duration;

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use urscript_controller::script_intake::{Intake, ScriptIntake};
use urscript_controller::{
    read_urp, translate_with, Cell, Config, Controller, Dashboard, FetchError, InputRegistry,
    RtdeSession, Submitted, RTDE_MAX_OUTBOX,
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
    /// A `.urp` file's bytes, read and translated (its External Control node answered
    /// with the given script).
    Urp(&'a [u8], &'a str),
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
            Action::Urp(bytes, script) => {
                if let Ok(program) = read_urp(bytes) {
                    let _ = translate_with(&program, |_| {
                        if script.is_empty() {
                            Err(FetchError::Timeout)
                        } else {
                            Ok(script.to_string())
                        }
                    });
                }
            }
        }
        while cell.poll_event().is_some() {}
        // The RTDE client's replies are bounded even when nobody takes them.
        assert!(rtde.outbox().len() <= RTDE_MAX_OUTBOX, "{}", rtde.outbox().len());
    }
});
