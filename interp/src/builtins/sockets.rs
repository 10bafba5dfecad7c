//! Every `socket_*` function of the e-Series 5.x manual, with its real signature and
//! defaults, on the robot model of `urscript_socket::robot` (the crate's byte formats,
//! timeouts and sentinels).

use urscript_socket::robot::ReadCall;

use super::{opt, req, Args, Builtin, Default, Domain, Out, SOCKET_NAME};
use crate::error::{Fault, RuntimeErrorKind};
use crate::event::{ReadRecord, MAX_READ_INPUT};
use crate::runtime::Runtime;
use crate::value::Value;

const D: Domain = Domain::Sockets;

/// The most sockets a program may have open at once. Each open socket is a connection
/// (a file descriptor and its buffers) of the process that runs the program, so without
/// a bound a program that opens sockets under new names in a loop takes every
/// descriptor of its host (the controller's listeners then cannot accept). UR's manuals
/// give no number; 64 is our choice, far above what programs open (a gripper, a camera,
/// a PC), as [`MAX_THREADS`](crate::machine::MAX_THREADS) is for threads. Opening one
/// more stops the program with a [`Limit`](RuntimeErrorKind::Limit) error.
pub const MAX_SOCKETS: usize = 64;
const TIMEOUT: super::Param = opt("timeout", Default::Float(2.0));

pub(super) const TABLE: &[Builtin] = &[
    Builtin::new(
        "socket_open",
        D,
        &[req("address"), req("port"), SOCKET_NAME],
        "Opens a TCP connection to address:port (the driver connects); True if it is up. An open name is closed first.",
        open,
    ),
    Builtin::new(
        "socket_close",
        D,
        &[SOCKET_NAME],
        "Closes the connection (nothing if it is not open).",
        close,
    ),
    Builtin::new(
        "socket_send_string",
        D,
        &[req("str"), SOCKET_NAME],
        "Sends the value's text (a string's bytes, a number or list as to_str writes it); False if the socket is not open or broken.",
        send_string,
    ),
    Builtin::new(
        "socket_send_line",
        D,
        &[req("str"), SOCKET_NAME],
        "Sends the value's text and a LF (\\n).",
        send_string,
    ),
    Builtin::new(
        "socket_send_byte",
        D,
        &[req("value"), SOCKET_NAME],
        "Sends one byte (0..255).",
        send_byte,
    ),
    Builtin::new(
        "socket_send_int",
        D,
        &[req("value"), SOCKET_NAME],
        "Sends a big-endian int32 (a float is truncated toward zero; outside the int32 range an error).",
        send_int,
    ),
    Builtin::new(
        "socket_set_var",
        D,
        &[req("name"), req("value"), SOCKET_NAME],
        "Sends `SET name value\\n`.",
        set_var,
    ),
    Builtin::new(
        "socket_get_var",
        D,
        &[req("name"), SOCKET_NAME],
        "Sends `GET name\\n` and reads the `name value\\n` reply as an int (0 after 2 s).",
        get_var,
    ),
    Builtin::new(
        "socket_read_ascii_float",
        D,
        &[req("number"), SOCKET_NAME, TIMEOUT],
        "Reads a `(f1, ..., fn)` tuple: [n, f1, ..., fn], or [0, nan...] on timeout.",
        read_counted,
    ),
    Builtin::new(
        "socket_read_binary_integer",
        D,
        &[req("number"), SOCKET_NAME, TIMEOUT],
        "Reads `number` big-endian int32s: [n, i1, ...], or [0, -1...] on timeout.",
        read_counted,
    ),
    Builtin::new(
        "socket_read_byte_list",
        D,
        &[req("number"), SOCKET_NAME, TIMEOUT],
        "Reads `number` bytes: [n, b1, ...], or [0, -1...] on timeout.",
        read_counted,
    ),
    Builtin::new(
        "socket_read_line",
        D,
        &[SOCKET_NAME, TIMEOUT],
        "Reads to the next LF, without it (\"\" on timeout).",
        read_line,
    ),
    Builtin::new(
        "socket_read_string",
        D,
        &[
            SOCKET_NAME,
            opt("prefix", Default::Str("")),
            opt("suffix", Default::Str("")),
            opt("interpret_escape", Default::Bool(false)),
            TIMEOUT,
        ],
        "Reads what arrives (between prefix and suffix when given) as a string (\"\" on timeout).",
        read_string,
    ),
];

fn open(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let host = a.text(0)?;
    let port = a.int(1)?;
    let port =
        u16::try_from(port).map_err(|_| format!("`socket_open`: port {port} out of range"))?;
    let socket = a.text(2)?;
    // Policy: opening an open name closes the old connection first.
    c.close(&socket);
    if c.sockets.count() >= MAX_SOCKETS {
        return Err(Fault::new(
            RuntimeErrorKind::Limit,
            format!(
                "`socket_open`: {MAX_SOCKETS} sockets are open already (at most {MAX_SOCKETS})"
            ),
        ));
    }
    c.events.push_back(crate::event::Event::Connect {
        socket_name: socket.clone(),
        host,
        port,
    });
    Ok(Out::Connect { socket })
}

fn close(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let socket = a.text(0)?;
    c.close(&socket);
    Ok(Out::Value(Value::None))
}

/// The value a send returns, with the reason when it is `False`.
fn sent(c: &mut Runtime, a: &mut Args, socket: &str, ok: bool) -> Result<Out, Fault> {
    c.flush(socket);
    if !ok {
        a.failure = Some(if !c.sockets.is_open(socket) {
            format!("the socket \"{socket}\" is not open")
        } else if c.sockets.is_broken(socket) {
            "the connection is broken (a write failed); the server has probably closed it".into()
        } else {
            "the robot refused to send".into()
        });
    }
    Ok(Out::Value(Value::Bool(ok)))
}

fn send_string(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let socket = a.text(1)?;
    let bytes = a.v[0].to_str_bytes();
    let ok = if a.name == "socket_send_line" {
        c.sockets.send_line(&socket, &bytes)
    } else {
        c.sockets.send_string(&socket, &bytes)
    };
    sent(c, a, &socket, ok)
}

fn send_byte(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let v = a.int(0)?;
    let v = u8::try_from(v)
        .map_err(|_| format!("`socket_send_byte`: value must be 0..255, got {v}"))?;
    let socket = a.text(1)?;
    let ok = c.sockets.send_byte(&socket, v);
    sent(c, a, &socket, ok)
}

/// `socket_send_int(value)`: an int, or a float truncated toward zero. UR's manual says
/// only "the int to send"; drivers send scaled floats without conversion (Machina's UR
/// driver, "works with SW3.0 and above", sends `socket_send_int(10000.0 * pose[0])`),
/// so the controller takes a float here. Truncation is our choice (the manuals are
/// silent); a float outside the int32 range, or not finite, is a type error.
fn send_int(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let v = match a.v[0] {
        Value::Float(x) if (f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&x.trunc()) => {
            x.trunc() as i32
        }
        _ => a.int(0)?,
    };
    let socket = a.text(1)?;
    let ok = c.sockets.send_int(&socket, v);
    sent(c, a, &socket, ok)
}

fn set_var(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let var = a.text(0)?;
    let v = a.int(1)?;
    let socket = a.text(2)?;
    let ok = c.sockets.set_var(&socket, &var, v)?;
    sent(c, a, &socket, ok)
}

fn get_var(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let name = a.text(0)?;
    let socket = a.text(1)?;
    start_read(c, socket, ReadCall::GetVar { name }, 2.0, a)
}

fn read_counted(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let n = a.int(0)?;
    let number = usize::try_from(n)
        .ok()
        .filter(|n| (1..=30).contains(n))
        .ok_or_else(|| format!("`{}`: number must be 1..30, got {n}", a.name))?;
    let socket = a.text(1)?;
    let timeout = a.num(2)?;
    let call = match a.name {
        "socket_read_ascii_float" => ReadCall::AsciiFloat { number },
        "socket_read_binary_integer" => ReadCall::BinaryInteger { number },
        _ => ReadCall::ByteList { number },
    };
    start_read(c, socket, call, timeout, a)
}

fn read_line(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let socket = a.text(0)?;
    let timeout = a.num(1)?;
    start_read(c, socket, ReadCall::Line, timeout, a)
}

fn read_string(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let socket = a.text(0)?;
    let call = ReadCall::String {
        prefix: a.bytes(1)?.to_vec(),
        suffix: a.bytes(2)?.to_vec(),
        interpret_escape: a.boolean(3)?,
    };
    let timeout = a.num(4)?;
    start_read(c, socket, call, timeout, a)
}

/// Starts a read that may wait `timeout` seconds: the value at once if the buffered
/// bytes complete it (or the socket is not open: the sentinel), else a wait.
fn start_read(
    c: &mut Runtime,
    socket: String,
    call: ReadCall,
    timeout: f64,
    args: &mut Args,
) -> Result<Out, Fault> {
    let now = c.now();
    // What the read sees first: the bytes already buffered (kept for the record).
    let (input, buffered_at_start) = if args.traced {
        let n = c.sockets.buffered_len(&socket);
        (c.sockets.buffered(&socket, MAX_READ_INPUT), n)
    } else {
        (Vec::new(), 0)
    };
    let done = c.sockets.start_read(&socket, &call, timeout, now)?;
    c.flush(&socket);
    Ok(match done {
        Some(result) => {
            let v = crate::sockets::to_value(&result);
            if !c.sockets.is_open(&socket) {
                args.failure = Some(format!("the socket \"{socket}\" is not open"));
            }
            args.read = Some(ReadRecord {
                call,
                result,
                input,
                buffered_at_start,
            });
            Out::Value(v)
        }
        None => Out::Read {
            socket,
            call,
            input,
            buffered_at_start,
        },
    })
}
