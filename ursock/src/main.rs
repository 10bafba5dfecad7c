//! `ursock`: the socket debug assistant for Universal Robots' URScript `socket_*`
//! functions. See `ursock --help`.
#![forbid(unsafe_code)]

mod client;
mod controller;
mod demo;
pub mod diagnose;
mod formats;
mod listen;
mod messages;
mod offline;
pub mod report;
#[macro_use]
pub mod out;
mod script;
mod show;
mod typed;
mod vars;
mod wait;

use clap::{Parser, Subcommand};
use urscript_socket::robot::ReadCall;

use formats::DecodeFormat;

/// Socket debug assistant for UR robots: every URScript socket format, both directions.
#[derive(Parser)]
#[command(name = "ursock", version, about = "Socket debug assistant for UR robots: every URScript socket format, both directions", long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// A server and a virtual robot on 127.0.0.1 walk through every socket function;
    /// prints both sides' traffic. Needs no robot.
    Demo,
    /// Connect to a device (camera, PLC, a robot program's server) as its TCP client:
    /// send what is typed, show what comes back as `listen` shows it.
    ///
    /// Each typed line (or --send TEXT) is sent: `hex 02 41 03` (or `hex: 02 41 03`) as
    /// those bytes, anything else as text with `\r \n \t \0 \\ \xHH` escapes and the
    /// --eol line end. Quits at the end of stdin (after --wait), when the device closes,
    /// or after --max-time.
    Client(client::ClientOptions),
    /// Listen for robots (socket_open connects here) and show their traffic decoded.
    ///
    /// Typed lines on stdin are sent: a reply spec (`floats 1 2 3`, `line OK`, `text a\r\n`,
    /// `hex 02 41 03`), `@N SPEC` for connection N when several are connected, `list`,
    /// `close N`, `help`. Variables (SET/GET) belong to the server: one table shared by
    /// every connection, so a value SET by one connection is read back by the next.
    Listen(listen::ListenOptions),
    /// A virtual robot running a URScript program against real servers, in real time:
    /// prints each socket call and what it returned, and textmsg/popup text.
    ///
    /// Exits 0 when the program ends or halts (or --max-time passes), 1 with `line N:`
    /// on a runtime error, and 1 at a protective stop (a move beyond the arm's reach,
    /// `protective_stop()`: a controller pauses the program there); a parse error names
    /// line and column and nothing is sent. `--fail-on` makes a halt or a popup fail too.
    Robot {
        /// Open `socket_0` to HOST:PORT before the program runs.
        #[arg(long)]
        connect: Option<String>,
        /// A URScript program: a file of statements, or one top-level `def` (as drivers
        /// send it to the controller), which is run.
        #[arg(long, conflicts_with = "eval")]
        script: Option<std::path::PathBuf>,
        /// The program file, as `--script FILE` (`ursock robot prog.script`).
        #[arg(value_name = "FILE", conflicts_with_all = ["script", "eval"])]
        file: Option<std::path::PathBuf>,
        /// Program lines given on the command line (repeatable).
        #[arg(short = 'e', long = "eval")]
        eval: Vec<String>,
        /// Also print the bytes sent and received, with times relative to the start.
        #[arg(long)]
        trace: bool,
        /// Print each call's result as one JSON object per line.
        #[arg(long)]
        json: bool,
        /// Copy everything printed (stdout and stderr notes) to FILE.
        #[arg(long, value_name = "FILE")]
        log: Option<std::path::PathBuf>,
        /// End the program after SECONDS (for programs that loop forever); exit 0 if
        /// nothing failed before.
        #[arg(long, value_name = "SECONDS")]
        max_time: Option<f64>,
        /// The controller's step in seconds: 0.002 (e-Series, the default), 0.008 (CB3).
        #[arg(long, value_name = "SECONDS", default_value_t = 0.002)]
        step_time: f64,
        /// The arm whose kinematics place the tool: ur3, ur5, ur10 (CB3), ur3e, ur5e, ur10e,
        /// ur16e, ur20, ur30.
        #[arg(long, value_name = "MODEL", default_value = "ur5e")]
        model: urscript_interp::kinematics::Model,
        /// Replace a function the program calls (a built-in not supported, or a helper of
        /// a URCap): `NAME` does nothing, `NAME=VALUE` returns the URScript constant VALUE
        /// (`0`, `True`, `"ok"`, `[1, 2]`, `p[0,0,0,0,0,0]`). Repeatable.
        #[arg(long, value_name = "NAME[=VALUE]")]
        stub: Vec<String>,
        /// A URCap's installation preamble (its definitions), run at the top of the
        /// program as PolyScope writes it, so the program can call the URCap's functions.
        /// Repeatable, in order.
        #[arg(long, value_name = "FILE")]
        preamble: Vec<std::path::PathBuf>,
        /// The arm at the start: its joints `q=[0,-1.2,1.5,-1.9,-1.57,0]` and what it
        /// senses: `digital_in[3]=True`, `analog_in[0]=4.2`,
        /// `tcp_force=[0,0,-9.8,0,0,0]`, `input_int_regs[2]=7`, `joint_temp[0]=41`,
        /// `operator_int=3`... (`--set help` lists every name). Repeatable.
        #[arg(long, value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// Exit 1 also when the program does this: `halt` (it ran `halt`),
        /// `error-popup` (a popup with error=True), `popup` (any popup). A compile or
        /// runtime error and a protective stop always exit 1. Comma-separated, repeatable.
        #[arg(long, value_name = "WHAT,...")]
        fail_on: Vec<String>,
        /// Run in virtual time while the program has no connection open: a sleep or a
        /// move ends at once instead of lasting its real length, with the same results
        /// (the same program times). While a connection is open, time is real.
        /// --max-time then counts program time.
        #[arg(long)]
        virtual_time: bool,
    },
    /// A virtual UR controller that unmodified clients drive: the dashboard server
    /// (port 29999) with its state machine (power, brakes, safety, programs).
    ///
    /// Ready when every port listens: then `--ready-file` is written and, with --json,
    /// a `ready` event follows the `listening` ones (`ursock wait HOST` waits for it
    /// from elsewhere). A dashboard `shutdown`, SIGTERM or SIGINT ends the program and
    /// closes every client, then the last event, `stopped`.
    ///
    /// Exit status: 0 stopped; 1 another failure; 2 a bad option or value; 3 a port in
    /// use; 4 a port that cannot be listened on for another reason.
    Controller(controller::ControllerOptions),
    /// Wait until a controller (`ursock controller`, URSim, a robot) is ready: its
    /// dashboard server greets, and its RTDE and primary ports accept. Exit status 0
    /// when ready; 1, saying what did not answer, after --timeout.
    Wait(wait::WaitOptions),
    /// Write the bytes a server (or with --robot, the robot) sends.
    /// Formats: floats, floats-lf, int32, bytes, string, line, framed PREFIX TEXT SUFFIX,
    /// var-reply NAME INT, hex HH...; robot: line, string, byte, int, set-var, get-var,
    /// stx-etx, value, hex HH....
    Encode {
        /// The format.
        format: String,
        /// The values.
        #[arg(allow_negative_numbers = true)]
        values: Vec<String>,
        /// Print hex instead of raw bytes.
        #[arg(long)]
        hex: bool,
        /// Interpret `\r \n \t \0 \\ \xHH` in text values (string, line, framed, stx-etx).
        #[arg(long)]
        escapes: bool,
        /// Encode the robot's sends instead of the server's.
        #[arg(long)]
        robot: bool,
    },
    /// Run a robot read function on the bytes of stdin (end of input = timeout) and print
    /// what URScript gets, one line per read.
    Read {
        /// The read: ascii-float N (socket_read_ascii_float), binary-integer N
        /// (socket_read_binary_integer), byte-list N (socket_read_byte_list), line
        /// (socket_read_line), string (socket_read_string, with --prefix, --suffix,
        /// --interpret-escape).
        #[arg(value_parser = clap::builder::PossibleValuesParser::new(
            formats::names::READS.iter().map(|n| n.name)
        ))]
        call: String,
        /// The number of values, for ascii-float, binary-integer and byte-list (1-30).
        number: Option<usize>,
        /// `read string`: the prefix argument.
        #[arg(long, allow_hyphen_values = true)]
        prefix: Option<String>,
        /// `read string`: the suffix argument.
        #[arg(long, allow_hyphen_values = true)]
        suffix: Option<String>,
        /// `read string`: interpret `\n`, `\t`, `\r` written in prefix and suffix.
        #[arg(long)]
        interpret_escape: bool,
        /// Repeat the read K times (1 or more).
        #[arg(long, default_value_t = 1)]
        repeat: usize,
        /// Print each result as one JSON object per line.
        #[arg(long)]
        json: bool,
        /// Prefix each result with the time since the start (`+0.003s`).
        #[arg(long)]
        timestamps: bool,
    },
    /// Decode what a robot sent (stdin), one message per line.
    Decode {
        /// The format.
        #[arg(value_enum)]
        format: DecodeFormat,
        /// Delimiter for `delimiter` (escapes `\r \n \t \0 \\ \xHH` are interpreted).
        #[arg(long, default_value = "\\n")]
        delimiter: String,
        /// One JSON object per line; text as {"encoding":"utf-8","text":...}, other
        /// bytes as {"encoding":"hex","hex":...}.
        #[arg(long)]
        json: bool,
        /// Accept a last message without its terminator at the end of input (line,
        /// delimiter, var, value). Without it, an unterminated rest is reported as cut off,
        /// for every format alike.
        #[arg(long)]
        allow_unterminated: bool,
    },
}

fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
        Command::Demo => demo::run(),
        Command::Listen(opts) => listen::listen(opts),
        Command::Client(opts) => client::run(opts),
        Command::Wait(opts) => wait::run(opts),
        Command::Controller(opts) => {
            if let Err(f) = controller::run(opts) {
                out::note(&f.message);
                std::process::exit(f.code);
            }
            Ok(())
        }
        Command::Robot {
            connect,
            script,
            file,
            eval,
            trace,
            json,
            log,
            max_time,
            step_time,
            model,
            stub,
            preamble,
            set,
            fail_on,
            virtual_time,
        } => {
            let fail_on = script::FailOn::parse(&fail_on)?;
            let Some(arm) = script::arm_from_settings(&set)? else {
                return Ok(());
            };
            let urcaps = script::read_preambles(&preamble)?;
            if let Some(path) = &log {
                out::open_log(path)?;
            }
            let max_time = match max_time {
                None => None,
                // Any positive time; one too long for the clock is no limit at all.
                Some(s) if s > 0.0 => Some(
                    std::time::Duration::try_from_secs_f64(s).unwrap_or(std::time::Duration::MAX),
                ),
                Some(s) => return Err(format!("--max-time {s}: give a number of seconds above 0")),
            };
            let step_time = std::time::Duration::try_from_secs_f64(step_time)
                .ok()
                .filter(|d| *d >= std::time::Duration::from_micros(100) && d.as_secs_f64() <= 1.0)
                .ok_or_else(|| {
                    format!("--step-time {step_time}: give seconds between 0.0001 and 1 (0.002 e-Series, 0.008 CB3)")
                })?;
            let stubs = stub
                .iter()
                .map(|s| urscript_interp::Stub::from_arg(s).map_err(|e| format!("--stub {s}: {e}")))
                .collect::<Result<Vec<_>, _>>()?;
            let text = match script.or(file) {
                Some(path) => {
                    let bytes =
                        std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
                    // Not UTF-8: the interpreter names the line and column of the bad byte.
                    String::from_utf8(bytes).map_err(|e| {
                        match urscript_interp::Program::parse_bytes(e.as_bytes()) {
                            Err(pe) => format!("{}: {pe}", path.display()),
                            Ok(_) => format!("{}: not UTF-8 text", path.display()),
                        }
                    })?
                }
                None if !eval.is_empty() => eval.join("\n"),
                None => return Err("give a program: FILE, --script FILE or -e 'CALL'".into()),
            };
            script::run(
                &text,
                connect.as_deref(),
                script::Options {
                    trace,
                    json,
                    max_time,
                    step_time,
                    model,
                    stubs,
                    preamble: urcaps,
                    arm,
                    fail_on,
                    virtual_time,
                },
            )
        }
        Command::Encode {
            format,
            values,
            hex,
            escapes,
            robot,
        } => offline::encode(&format, &values, hex, escapes, robot),
        Command::Read {
            call,
            number,
            prefix,
            suffix,
            interpret_escape,
            repeat,
            json,
            timestamps,
        } => {
            if repeat == 0 {
                return Err("--repeat 0: give the number of reads, 1 or more".into());
            }
            let name = formats::lookup(formats::names::READS, &call)
                .ok_or_else(|| format!("unknown read {call:?}"))?;
            let counted = !matches!(name.core, Some("line" | "string"));
            if !counted && number.is_some() {
                return Err(format!("read {call} takes no number of values"));
            }
            let string_args = prefix.is_some() || suffix.is_some() || interpret_escape;
            if name.core != Some("string") && string_args {
                return Err(
                    "--prefix, --suffix and --interpret-escape are for `read string`".into(),
                );
            }
            let mut read = formats::read_call(name, number).map_err(|e| format!("read {e}"))?;
            if let ReadCall::String {
                prefix: p,
                suffix: s,
                interpret_escape: i,
            } = &mut read
            {
                *p = prefix.unwrap_or_default().into_bytes();
                *s = suffix.unwrap_or_default().into_bytes();
                *i = interpret_escape;
            }
            offline::read(read, repeat, json, timestamps)
        }
        Command::Decode {
            format,
            delimiter,
            json,
            allow_unterminated,
        } => offline::decode(
            format,
            &formats::delimiter(&delimiter)?,
            json,
            allow_unterminated,
        ),
    }
}

fn main() {
    out::start_clock();
    let cli = Cli::parse();
    if let Err(msg) = run(cli) {
        out::note(&msg);
        std::process::exit(1);
    }
}
