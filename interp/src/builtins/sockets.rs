//! Every `socket_*` function of the e-Series 5.x manual, with its real signature and
//! defaults, on the robot model of `urscript_socket::robot` (the crate's byte formats,
//! timeouts and sentinels).

use urscript_socket::robot::ReadCall;

use super::{builtin, Args, Builtin, Domain, Out};
use crate::error::{Fault, RuntimeErrorKind};
use crate::event::{ReadRecord, MAX_READ_INPUT};
use crate::native::FromArg;
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

pub(super) const TABLE: &[Builtin] = &[
    builtin!(
        socket_open(address: String, port: i32, socket_name: String = Str("socket_0")) => open,
        "Opens a TCP connection to address:port (the driver connects); True if it is up. An open name is closed first.",
    ),
    builtin!(
        socket_close(socket_name: String = Str("socket_0")) => close,
        "Closes the connection (nothing if it is not open).",
    ),
    builtin!(
        socket_send_string(str: &Value, socket_name: String = Str("socket_0"))
            => |c, x, v, s| send_string(c, x, Ending::None, v, s),
        "Sends the value's text (a string's bytes, a number or list as to_str writes it); False if the socket is not open or broken.",
    ),
    builtin!(
        socket_send_line(str: &Value, socket_name: String = Str("socket_0"))
            => |c, x, v, s| send_string(c, x, Ending::Lf, v, s),
        "Sends the value's text and a LF (\\n).",
    ),
    builtin!(
        socket_send_byte(value: i32, socket_name: String = Str("socket_0")) => send_byte,
        "Sends one byte (0..255).",
    ),
    builtin!(
        socket_send_int(value: SendInt, socket_name: String = Str("socket_0")) => send_int,
        "Sends a big-endian int32 (a float is truncated toward zero; outside the int32 range an error).",
    ),
    builtin!(
        socket_set_var(name: String, value: i32, socket_name: String = Str("socket_0")) => set_var,
        "Sends `SET name value\\n`.",
    ),
    builtin!(
        socket_get_var(name: String, socket_name: String = Str("socket_0")) => get_var,
        "Sends `GET name\\n` and reads the `name value\\n` reply as an int (0 after 2 s).",
    ),
    builtin!(
        socket_read_ascii_float(
            number: i32,
            socket_name: String = Str("socket_0"),
            timeout: f64 = Float(2.0),
        ) => |c, x, n, s, t| read_counted(c, x, Counted::AsciiFloat, n, s, t),
        "Reads a `(f1, ..., fn)` tuple: [n, f1, ..., fn], or [0, nan...] on timeout.",
    ),
    builtin!(
        socket_read_binary_integer(
            number: i32,
            socket_name: String = Str("socket_0"),
            timeout: f64 = Float(2.0),
        ) => |c, x, n, s, t| read_counted(c, x, Counted::BinaryInteger, n, s, t),
        "Reads `number` big-endian int32s: [n, i1, ...], or [0, -1...] on timeout.",
    ),
    builtin!(
        socket_read_byte_list(
            number: i32,
            socket_name: String = Str("socket_0"),
            timeout: f64 = Float(2.0),
        ) => |c, x, n, s, t| read_counted(c, x, Counted::ByteList, n, s, t),
        "Reads `number` bytes: [n, b1, ...], or [0, -1...] on timeout.",
    ),
    builtin!(
        socket_read_line(socket_name: String = Str("socket_0"), timeout: f64 = Float(2.0))
            => |c, x, s, t| start_read(c, s, ReadCall::Line, t, x),
        "Reads to the next LF, without it (\"\" on timeout).",
    ),
    builtin!(
        socket_read_string(
            socket_name: String = Str("socket_0"),
            prefix: &[u8] = Str(""),
            suffix: &[u8] = Str(""),
            interpret_escape: bool = Bool(false),
            timeout: f64 = Float(2.0),
        ) => read_string,
        "Reads what arrives (between prefix and suffix when given) as a string (\"\" on timeout).",
    ),
];

fn open(
    c: &mut Runtime,
    _: &mut Args,
    host: String,
    port: i32,
    socket: String,
) -> Result<Out, Fault> {
    let port =
        u16::try_from(port).map_err(|_| format!("`socket_open`: port {port} out of range"))?;
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

fn close(c: &mut Runtime, _: &mut Args, socket: String) -> Result<Out, Fault> {
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

/// What `socket_send_string` and `socket_send_line` put after the text.
#[derive(Clone, Copy)]
enum Ending {
    /// Nothing.
    None,
    /// A LF.
    Lf,
}

fn send_string(
    c: &mut Runtime,
    a: &mut Args,
    ending: Ending,
    v: &Value,
    socket: String,
) -> Result<Out, Fault> {
    let bytes = v.to_str_bytes();
    let ok = match ending {
        Ending::None => c.sockets.send_string(&socket, &bytes),
        Ending::Lf => c.sockets.send_line(&socket, &bytes),
    };
    sent(c, a, &socket, ok)
}

fn send_byte(c: &mut Runtime, a: &mut Args, v: i32, socket: String) -> Result<Out, Fault> {
    let v = u8::try_from(v)
        .map_err(|_| format!("`socket_send_byte`: value must be 0..255, got {v}"))?;
    let ok = c.sockets.send_byte(&socket, v);
    sent(c, a, &socket, ok)
}

/// The argument of `socket_send_int(value)`: an int, or a float truncated toward zero.
/// UR's manual says only "the int to send"; drivers send scaled floats without
/// conversion (Machina's UR driver, "works with SW3.0 and above", sends
/// `socket_send_int(10000.0 * pose[0])`), so the controller takes a float here.
/// Truncation is our choice (the manuals are silent); a float outside the int32 range,
/// or not finite, is a type error.
struct SendInt(i32);

impl FromArg<'_> for SendInt {
    fn from_arg(a: &Args, v: &Value, i: usize) -> Result<Self, Fault> {
        match *v {
            Value::Float(x) if (f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&x.trunc()) => {
                Ok(SendInt(x.trunc() as i32))
            }
            _ => i32::from_arg(a, v, i).map(SendInt),
        }
    }
}

fn send_int(c: &mut Runtime, a: &mut Args, v: SendInt, socket: String) -> Result<Out, Fault> {
    let ok = c.sockets.send_int(&socket, v.0);
    sent(c, a, &socket, ok)
}

fn set_var(
    c: &mut Runtime,
    a: &mut Args,
    var: String,
    v: i32,
    socket: String,
) -> Result<Out, Fault> {
    let ok = c.sockets.set_var(&socket, &var, v)?;
    sent(c, a, &socket, ok)
}

fn get_var(c: &mut Runtime, a: &mut Args, name: String, socket: String) -> Result<Out, Fault> {
    start_read(c, socket, ReadCall::GetVar { name }, 2.0, a)
}

/// What `socket_read_ascii_float`, `socket_read_binary_integer` and
/// `socket_read_byte_list` read `number` of.
#[derive(Clone, Copy)]
enum Counted {
    AsciiFloat,
    BinaryInteger,
    ByteList,
}

fn read_counted(
    c: &mut Runtime,
    a: &mut Args,
    what: Counted,
    n: i32,
    socket: String,
    timeout: f64,
) -> Result<Out, Fault> {
    let number = usize::try_from(n)
        .ok()
        .filter(|n| (1..=30).contains(n))
        .ok_or_else(|| format!("`{}`: number must be 1..30, got {n}", a.name))?;
    let call = match what {
        Counted::AsciiFloat => ReadCall::AsciiFloat { number },
        Counted::BinaryInteger => ReadCall::BinaryInteger { number },
        Counted::ByteList => ReadCall::ByteList { number },
    };
    start_read(c, socket, call, timeout, a)
}

fn read_string(
    c: &mut Runtime,
    a: &mut Args,
    socket: String,
    prefix: &[u8],
    suffix: &[u8],
    interpret_escape: bool,
    timeout: f64,
) -> Result<Out, Fault> {
    let call = ReadCall::String {
        prefix: prefix.to_vec(),
        suffix: suffix.to_vec(),
        interpret_escape,
    };
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

#[cfg(test)]
mod tests {
    use super::super::{all, Default, Domain};

    /// The manual's socket functions are all here, and each takes
    /// `socket_name="socket_0"`.
    #[test]
    fn every_socket_function_has_socket_name_socket_0() {
        let manual = [
            "socket_close",
            "socket_get_var",
            "socket_open",
            "socket_read_ascii_float",
            "socket_read_binary_integer",
            "socket_read_byte_list",
            "socket_read_line",
            "socket_read_string",
            "socket_send_byte",
            "socket_send_int",
            "socket_send_line",
            "socket_send_string",
            "socket_set_var",
        ];
        // (`rpc_factory` is of the domain too.)
        let ours: Vec<_> = all()
            .iter()
            .filter(|b| b.domain == Domain::Sockets && b.name.starts_with("socket_"))
            .collect();
        let names: Vec<&str> = ours.iter().map(|b| b.name).collect();
        assert_eq!(names, manual);
        for b in ours {
            let p = b.param("socket_name").map(|i| b.params[i].default);
            assert_eq!(p, Some(Default::Str("socket_0")), "{}", b.name);
        }
    }
}
