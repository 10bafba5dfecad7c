//! One robot socket as a sans-IO state machine: bytes, reads, deadlines.

use alloc::boxed::Box;
use alloc::string::String;
use alloc::vec::Vec;
use core::time::Duration;

use crate::format::{AnyDecoder, Counted};
use crate::to_str::Value;
use crate::{DecodeError, RecvBuffer};

use super::{IntList, Policy, ReadCall, ReadResult, RobotError, ShortRead, Timeout};

/// The read in progress: the call, its decoder and when it gives up (`None`: never).
#[derive(Debug)]
struct Pending {
    call: ReadCall,
    reader: AnyDecoder,
    deadline: Option<Duration>,
}

/// One socket of the robot (`socket_open(address, port, socket_name)`): its bounded
/// receive buffer, its outgoing bytes and the read in progress. Sans-IO: the caller moves
/// bytes and reports time.
///
/// ```
/// use std::time::Duration;
/// use urscript_socket::robot::{Policy, ReadCall, SocketConnection, Timeout};
/// let mut s = SocketConnection::new("socket_0", Policy::default());
/// s.receive(b">hello<>world<");
/// let call = ReadCall::String { prefix: b">".to_vec(), suffix: b"<".to_vec(), interpret_escape: false };
/// s.start_read(call.clone(), Timeout::Forever, Duration::ZERO).unwrap();
/// assert_eq!(s.poll_read().unwrap().to_urscript(), "\"hello\"");
/// s.start_read(call, Timeout::Forever, Duration::ZERO).unwrap();
/// assert_eq!(s.poll_read().unwrap().to_urscript(), "\"world\"");
/// ```
#[derive(Debug)]
pub struct SocketConnection {
    name: String,
    policy: Policy,
    rx: RecvBuffer<Box<[u8]>>,
    tx: Vec<u8>,
    pending: Option<Pending>,
    peer_closed: bool,
    /// A send failed: the connection is gone for writing; sends return false.
    send_broken: bool,
    last_failure: Option<DecodeError>,
}

impl SocketConnection {
    /// A connected socket named `name` (URScript's `socket_name`).
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// assert_eq!(SocketConnection::new("cam", Policy::default()).name(), "cam");
    /// ```
    pub fn new(name: &str, policy: Policy) -> Self {
        SocketConnection {
            name: String::from(name),
            policy,
            rx: RecvBuffer::with_capacity(policy.receive_capacity),
            tx: Vec::new(),
            pending: None,
            peer_closed: false,
            send_broken: false,
            last_failure: None,
        }
    }

    /// The socket's name.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// assert_eq!(SocketConnection::new("socket_0", Policy::default()).name(), "socket_0");
    /// ```
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The policy in force.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// assert_eq!(*SocketConnection::new("s", Policy::default()).policy(), Policy::default());
    /// ```
    pub fn policy(&self) -> &Policy {
        &self.policy
    }

    /// Adds bytes that arrived from the server and returns how many were accepted (fewer
    /// when the receive buffer is full; the rest must be offered again later).
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy { receive_capacity: 4, ..Policy::default() });
    /// assert_eq!(s.receive(b"abcdef"), 4);
    /// ```
    pub fn receive(&mut self, bytes: &[u8]) -> usize {
        self.rx.extend(bytes)
    }

    /// Free space in the receive buffer, for a transport to read into; follow with
    /// [`commit_received`](Self::commit_received).
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.receive_space()[..2].copy_from_slice(b"hi");
    /// s.commit_received(2);
    /// assert_eq!(s.buffered(), b"hi");
    /// ```
    pub fn receive_space(&mut self) -> &mut [u8] {
        self.rx.spare()
    }

    /// Marks `n` bytes of [`receive_space`](Self::receive_space) as received.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.commit_received(0);
    /// assert!(s.buffered().is_empty());
    /// ```
    pub fn commit_received(&mut self, n: usize) {
        self.rx.commit(n);
    }

    /// The bytes received and not yet read: what the next read will see.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.receive(b"ack");
    /// assert_eq!(s.buffered(), b"ack");
    /// ```
    pub fn buffered(&self) -> &[u8] {
        self.rx.data()
    }

    /// The server closed the connection: pending and later reads resolve to their
    /// sentinels once the buffered bytes do not complete them.
    ///
    /// ```
    /// # use std::time::Duration;
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection, Timeout};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.start_read(ReadCall::Line, Timeout::Forever, Duration::ZERO).unwrap();
    /// s.peer_closed();
    /// assert_eq!(s.poll_read().unwrap().to_urscript(), "\"\"");
    /// ```
    pub fn peer_closed(&mut self) {
        self.peer_closed = true;
    }

    /// True once [`peer_closed`](Self::peer_closed) was reported.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// assert!(!SocketConnection::new("s", Policy::default()).is_peer_closed());
    /// ```
    pub fn is_peer_closed(&self) -> bool {
        self.peer_closed
    }

    /// Why the last read that failed on malformed bytes failed (the robot only shows the
    /// sentinel; the emulation can say what and where).
    ///
    /// ```
    /// # use std::time::Duration;
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection, Timeout};
    /// use urscript_socket::ErrorKind;
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.receive(b"(1,x)");
    /// s.start_read(ReadCall::AsciiFloat { number: 2 }, Timeout::default(), Duration::ZERO).unwrap();
    /// assert_eq!(s.poll_read().unwrap().to_urscript(), "[0, nan, nan]");
    /// assert_eq!(s.last_failure().unwrap().kind(), ErrorKind::InvalidNumber);
    /// ```
    pub fn last_failure(&self) -> Option<DecodeError> {
        self.last_failure
    }

    /// The read in progress, if any.
    ///
    /// ```
    /// # use std::time::Duration;
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection, Timeout};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.start_read(ReadCall::Line, Timeout::Forever, Duration::ZERO).unwrap();
    /// assert_eq!(s.pending_read(), Some(&ReadCall::Line));
    /// ```
    pub fn pending_read(&self) -> Option<&ReadCall> {
        self.pending.as_ref().map(|p| &p.call)
    }

    /// Starts a read at time `now` that may wait `timeout` (`socket_get_var` always waits
    /// 2 s, whatever is asked, as on the controller). Arguments are checked first (`number`
    /// in 1..=30, names, pattern lengths); a refused call consumes nothing. `GetVar` queues
    /// `GET name\n` to the outgoing bytes.
    ///
    /// A deadline past the end of representable time (`timeout=1e19`) means "forever",
    /// never an overflow.
    ///
    /// ```
    /// # use std::time::Duration;
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection, Timeout};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.start_read(ReadCall::GetVar { name: "POS_X".into() }, Timeout::Forever, Duration::ZERO).unwrap();
    /// assert_eq!(s.take_outgoing(), b"GET POS_X\n");
    /// assert_eq!(s.poll_timeout(), Some(Duration::from_secs(2)));
    /// ```
    pub fn start_read(
        &mut self,
        call: ReadCall,
        timeout: Timeout,
        now: Duration,
    ) -> Result<(), RobotError> {
        if self.pending.is_some() {
            return Err(RobotError::ReadPending);
        }
        let reader = call.format().decoder_with(self.policy.float)?;
        if let ReadCall::GetVar { name } = &call {
            crate::var::encode_get_var(name, &mut self.tx)?;
        }
        let wait = match call {
            ReadCall::GetVar { .. } => Timeout::default(),
            _ => timeout,
        };
        let deadline = match wait {
            Timeout::After(d) => now.checked_add(d),
            Timeout::Forever => None,
        };
        self.pending = Some(Pending {
            call,
            reader,
            deadline,
        });
        Ok(())
    }

    /// When the pending read gives up, if it has a deadline: the moment to call
    /// [`handle_timeout`](Self::handle_timeout) unless bytes complete it first.
    ///
    /// ```
    /// # use std::time::Duration;
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection, Timeout};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// assert_eq!(s.poll_timeout(), None);
    /// let t = Timeout::from_secs_f64(0.5);
    /// s.start_read(ReadCall::Line, t, Duration::from_secs(10)).unwrap();
    /// assert_eq!(s.poll_timeout(), Some(Duration::from_millis(10_500)));
    /// ```
    pub fn poll_timeout(&self) -> Option<Duration> {
        self.pending.as_ref()?.deadline
    }

    /// The pending read's result if the buffered bytes complete it (or the peer closed,
    /// or they make it fail); `None` while it must wait.
    ///
    /// A read that can never complete (the receive buffer is full and holds no complete
    /// message) ends with its sentinel at once when it has no deadline; with a deadline it
    /// waits for it, as a full TCP window would hold the robot's read until its timeout.
    ///
    /// ```
    /// # use std::time::Duration;
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection, Timeout};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.start_read(ReadCall::BinaryInteger { number: 1 }, Timeout::default(), Duration::ZERO).unwrap();
    /// s.receive(&[0xFF, 0xFF]);
    /// assert!(s.poll_read().is_none());
    /// s.receive(&[0xFF, 0xFF]);
    /// assert_eq!(s.poll_read().unwrap().to_urscript(), "[1, -1]");
    /// ```
    pub fn poll_read(&mut self) -> Option<ReadResult> {
        let pending = self.pending.as_mut()?;
        let outcome = match self.rx.decode_without_overflow(&mut pending.reader) {
            Ok(Some(message)) => Outcome::Done(ReadResult::from_message(&message)),
            Ok(None) => Outcome::Waiting,
            Err(e) => Outcome::Failed(e),
        };
        let result = match outcome {
            Outcome::Done(r) => r,
            // A malformed message fails the read; its bytes are already dropped.
            Outcome::Failed(e) => {
                self.last_failure = Some(e);
                pending.call.sentinel()
            }
            Outcome::Waiting if self.rx.is_full() && resync(&mut self.rx, &mut pending.reader) => {
                // Room was made: wait for more bytes.
                return None;
            }
            Outcome::Waiting
                if self.peer_closed || (self.rx.is_full() && pending.deadline.is_none()) =>
            {
                return self.give_up();
            }
            Outcome::Waiting => return None,
        };
        self.pending = None;
        Some(result)
    }

    /// Time passed: if the pending read's deadline is at or before `now`, the read ends
    /// with its sentinel (`[0, nan...]`, `[0, -1...]`, `""`, `0`), or, for int/byte reads
    /// under [`ShortRead::WholeValues`] (the default), with the whole values that arrived.
    /// A string read leaves the buffer unchanged. `None` if no read was pending or its time
    /// has not come.
    ///
    /// ```
    /// # use std::time::Duration;
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection, Timeout};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.receive(&[0, 0, 0, 7, 0]);
    /// s.start_read(ReadCall::BinaryInteger { number: 2 }, Timeout::default(), Duration::ZERO).unwrap();
    /// assert!(s.poll_read().is_none());
    /// assert!(s.handle_timeout(Duration::from_millis(1999)).is_none());
    /// // One whole value arrived: it is counted and consumed; the partial one stays.
    /// assert_eq!(s.handle_timeout(Duration::from_secs(2)).unwrap().to_urscript(), "[1, 7, -1]");
    /// assert_eq!(s.buffered(), &[0][..]);
    /// ```
    pub fn handle_timeout(&mut self, now: Duration) -> Option<ReadResult> {
        match self.pending.as_ref()?.deadline {
            Some(deadline) if deadline <= now => self.give_up(),
            _ => None,
        }
    }

    /// One step of the pending read at time `now`: what the driver must do next. This is
    /// the whole read loop of every I/O driver, written once: the driver calls it, does
    /// what the [`Step`] says, and calls it again until [`Step::Done`]. It is
    /// [`poll_read`](Self::poll_read), then [`handle_timeout`](Self::handle_timeout)`(now)`,
    /// then [`poll_timeout`](Self::poll_timeout) turned into an instruction.
    ///
    /// ```
    /// # use std::time::Duration;
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection, Step, Timeout};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// assert_eq!(s.next(Duration::ZERO), Step::Idle);
    /// s.start_read(ReadCall::Line, Timeout::from_secs_f64(0.5), Duration::ZERO).unwrap();
    /// let until = Some(Duration::from_millis(500));
    /// assert_eq!(s.next(Duration::ZERO), Step::NeedBytes { until });
    /// s.receive(b"ok\n");
    /// let Step::Done(line) = s.next(Duration::from_millis(1)) else { panic!() };
    /// assert_eq!(line.to_urscript(), "\"ok\"");
    /// s.start_read(ReadCall::Line, Timeout::from_secs_f64(0.5), Duration::ZERO).unwrap();
    /// let Step::Done(timed_out) = s.next(Duration::from_millis(500)) else { panic!() };
    /// assert_eq!(timed_out.to_urscript(), "\"\"");
    /// ```
    pub fn next(&mut self, now: Duration) -> Step {
        if self.pending.is_none() {
            return Step::Idle;
        }
        if let Some(result) = self.poll_read() {
            return Step::Done(result);
        }
        if let Some(result) = self.handle_timeout(now) {
            return Step::Done(result);
        }
        let until = self.poll_timeout();
        if !self.rx.spare().is_empty() {
            return Step::NeedBytes { until };
        }
        match until {
            // Full buffer, incomplete read: only the deadline can end it.
            Some(until) => Step::Sleep { until },
            // A read with no deadline over a full buffer already ended in `poll_read`;
            // should one get here, it ends the same way.
            None => self.give_up().map_or(Step::Idle, Step::Done),
        }
    }

    /// Ends the pending read now, as its timeout would (the caller gives up waiting, or
    /// the program stops). `None` if no read was pending.
    ///
    /// ```
    /// # use std::time::Duration;
    /// # use urscript_socket::robot::{Policy, ReadCall, SocketConnection, Timeout};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.start_read(ReadCall::AsciiFloat { number: 2 }, Timeout::Forever, Duration::ZERO).unwrap();
    /// assert_eq!(s.give_up().unwrap().to_urscript(), "[0, nan, nan]");
    /// ```
    pub fn give_up(&mut self) -> Option<ReadResult> {
        let Pending {
            call, mut reader, ..
        } = self.pending.take()?;
        if self.policy.short_read == ShortRead::WholeValues {
            let number = match call {
                ReadCall::BinaryInteger { number } | ReadCall::ByteList { number } => number,
                _ => 0,
            };
            let data = self.rx.data();
            let taken = match reader.as_counted() {
                Counted::Int32(d) => d
                    .take_partial(data)
                    .map(|(v, n)| (IntList::read(number, v.iter()), n)),
                Counted::Bytes(d) => d
                    .take_partial(data)
                    .map(|(b, n)| (IntList::read(number, b.iter().map(|&x| i32::from(x))), n)),
                _ => None,
            };
            if let Some((list, used)) = taken {
                self.rx.consume(used);
                return Some(ReadResult::Ints(list));
            }
        }
        Some(call.sentinel())
    }

    /// Sending failed (the transport reported the peer gone): later sends return false,
    /// as `socket_send_*` returns False on the controller once the connection is broken.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// assert!(s.send_line(b"a"));
    /// s.send_failed();
    /// assert!(!s.send_line(b"b"));
    /// ```
    pub fn send_failed(&mut self) {
        self.send_broken = true;
        self.tx.clear();
    }

    /// Queues `text` unchanged: `socket_send_string(text)`.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.send_string(b"hi");
    /// assert_eq!(s.take_outgoing(), b"hi");
    /// ```
    pub fn send_string(&mut self, text: &[u8]) -> bool {
        self.queue(|tx| tx.extend_from_slice(text))
    }

    /// Queues `text` and a LF: `socket_send_line(text)`. The bytes of `text` go out as
    /// they are (URScript does not check them).
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.send_line(b"hello");
    /// assert_eq!(s.take_outgoing(), [0x68, 0x65, 0x6C, 0x6C, 0x6F, 0x0A]);
    /// ```
    pub fn send_line(&mut self, text: &[u8]) -> bool {
        self.queue(|tx| {
            tx.extend_from_slice(text);
            tx.push(b'\n');
        })
    }

    /// Queues the `to_str` text of a number, bool, list or pose:
    /// `socket_send_string(value)`, or with `line` `socket_send_line(value)`.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// use urscript_socket::to_str::Value;
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.send_value(&Value::Pose([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]), false).unwrap();
    /// assert_eq!(s.take_outgoing(), b"p[1, 2, 3, 4, 5, 6]");
    /// ```
    pub fn send_value(&mut self, value: &Value<'_>, line: bool) -> Result<bool, RobotError> {
        let mut text = Vec::new();
        crate::to_str::encode_value(value, &mut text)?;
        if line {
            text.push(b'\n');
        }
        Ok(self.queue(|tx| tx.extend_from_slice(&text)))
    }

    /// Queues one byte: `socket_send_byte(value)` (2 = STX, 3 = ETX, 10 = LF).
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.send_byte(2);
    /// s.send_string(b"hi");
    /// s.send_byte(3);
    /// assert_eq!(s.take_outgoing(), [0x02, 0x68, 0x69, 0x03]);
    /// ```
    pub fn send_byte(&mut self, value: u8) -> bool {
        self.queue(|tx| tx.push(value))
    }

    /// Queues a big-endian int32: `socket_send_int(value)`.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.send_int(-1);
    /// assert_eq!(s.take_outgoing(), [0xFF; 4]);
    /// ```
    pub fn send_int(&mut self, value: i32) -> bool {
        self.queue(|tx| tx.extend_from_slice(&value.to_be_bytes()))
    }

    /// Queues `SET name value\n`: `socket_set_var(name, value)`.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.set_var("POS_Y", 2200).unwrap();
    /// assert_eq!(s.take_outgoing(), b"SET POS_Y 2200\n");
    /// ```
    pub fn set_var(&mut self, name: &str, value: i32) -> Result<bool, RobotError> {
        let mut text = Vec::new();
        crate::var::encode_set_var(name, value, &mut text)?;
        Ok(self.queue(|tx| tx.extend_from_slice(&text)))
    }

    /// Queues bytes unless the connection is broken for writing; true if queued (what
    /// `socket_send_*` returns).
    fn queue(&mut self, put: impl FnOnce(&mut Vec<u8>)) -> bool {
        if self.send_broken {
            return false;
        }
        put(&mut self.tx);
        true
    }

    /// True once a send failed ([`send_failed`](Self::send_failed)).
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// assert!(!SocketConnection::new("s", Policy::default()).is_send_broken());
    /// ```
    pub fn is_send_broken(&self) -> bool {
        self.send_broken
    }

    /// The bytes queued for the server so far (not yet taken).
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.send_byte(10);
    /// assert_eq!(s.outgoing(), b"\n");
    /// ```
    pub fn outgoing(&self) -> &[u8] {
        &self.tx
    }

    /// Takes the bytes queued for the server, leaving the queue empty.
    ///
    /// ```
    /// # use urscript_socket::robot::{Policy, SocketConnection};
    /// let mut s = SocketConnection::new("s", Policy::default());
    /// s.send_int(1);
    /// assert_eq!(s.take_outgoing().len(), 4);
    /// assert!(s.outgoing().is_empty());
    /// ```
    pub fn take_outgoing(&mut self) -> Vec<u8> {
        core::mem::take(&mut self.tx)
    }
}

/// What a driver must do for the pending read: [`SocketConnection::next`]'s answer.
///
/// Times are on the driver's clock, as everywhere in the model (a
/// [`Duration`](core::time::Duration) since the driver's epoch).
#[allow(clippy::large_enum_variant)]
#[must_use]
#[derive(Debug, Clone, PartialEq)]
pub enum Step {
    /// The read ended: its value, its sentinel, or the whole values that arrived.
    Done(ReadResult),
    /// Receive bytes from the transport into
    /// [`receive_space`](SocketConnection::receive_space) and
    /// [`commit_received`](SocketConnection::commit_received) them (or report
    /// [`peer_closed`](SocketConnection::peer_closed)), waiting at most until `until`
    /// (`None`: no deadline); then step again.
    NeedBytes {
        /// The read's deadline.
        until: Option<Duration>,
    },
    /// The receive buffer is full and holds no complete message: only the deadline can
    /// end the read. Wait until `until` without receiving, then step again.
    Sleep {
        /// The read's deadline.
        until: Duration,
    },
    /// No read is pending: nothing to wait for.
    Idle,
}

#[allow(clippy::large_enum_variant)]
enum Outcome {
    Done(ReadResult),
    Failed(DecodeError),
    Waiting,
}

/// A full receive buffer that holds no complete message: the decoder says how many
/// leading bytes it can never use (a `socket_read_string` drops what cannot begin its
/// prefix; the framer owns that scan) and they are consumed. True if room was made.
fn resync(rx: &mut RecvBuffer<Box<[u8]>>, reader: &mut AnyDecoder) -> bool {
    let drop = reader.drop_before_prefix(rx.data());
    rx.consume(drop);
    drop > 0
}
