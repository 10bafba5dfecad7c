//! Blocking adapters over `std::io::Read` and `Write`.
//!
//! [`MessageReader`] is an `Iterator` of owned messages (`for line in reader`), or lends
//! each message straight from its buffer with [`next_with`](MessageReader::next_with)
//! (no copy). [`MessageWriter`] writes each message whole. Both errors convert into
//! `std::io::Error`, so `?` works in a function returning `io::Result`.
//!
//! ```no_run
//! use std::net::TcpListener;
//! use urscript_socket::adapters::blocking::{MessageReader, MessageWriter};
//! use urscript_socket::{ascii_float::encode_float_tuple, line::LineDecoder};
//!
//! fn main() -> std::io::Result<()> {
//!     let listener = TcpListener::bind("0.0.0.0:30000")?;
//!     let (robot, _) = listener.accept()?;
//!     let mut replies = MessageWriter::new(robot.try_clone()?);
//!     for request in MessageReader::new(robot, LineDecoder::new()) {
//!         match request {
//!             Ok(line) if line == b"shoot" => {
//!                 replies.send(|out| encode_float_tuple(&[0.4, -0.2, 0.3, 0.0, 3.14, 0.0], false, out))?
//!             }
//!             Ok(_) => {}
//!             Err(e) if e.is_recoverable() => eprintln!("skipped: {e}"),
//!             Err(e) => return Err(e.into()),
//!         }
//!     }
//!     Ok(())
//! }
//! ```

use std::boxed::Box;
use std::io::{self, Read, Write};
use std::vec::Vec;

use crate::adapters::OwnedDecoder;
use crate::{Decode, EncodeError, RecvBuffer};

/// Default receive buffer of a [`MessageReader`]: 64 KiB, above every core decoder's
/// default bound.
pub const DEFAULT_CAPACITY: usize = 64 * 1024;

/// Why a [`MessageReader`] call failed: the adapters' [`AdapterError`](crate::adapters::AdapterError)
/// over `std::io::Error`. Converts into `std::io::Error`.
///
/// ```
/// use urscript_socket::adapters::blocking::ReadError;
/// let e = ReadError::TimedOut;
/// assert_eq!(e.to_string(), "no complete message before the read timeout");
/// assert_eq!(std::io::Error::from(e).kind(), std::io::ErrorKind::TimedOut);
/// ```
pub type ReadError = crate::adapters::AdapterError<io::Error>;

/// Why a [`MessageWriter::send`] failed (`Io` or `Encode`): the same type as
/// [`ReadError`]. Converts into `std::io::Error`.
///
/// ```
/// use urscript_socket::{adapters::blocking::WriteError, EncodeError};
/// let e = WriteError::Encode(EncodeError::NoValues);
/// assert_eq!(std::io::Error::from(e).kind(), std::io::ErrorKind::InvalidInput);
/// ```
pub type WriteError = crate::adapters::AdapterError<io::Error>;

/// Reads messages of one format from a blocking reader: a core decoder over a bounded
/// buffer.
///
/// Two ways to take messages:
/// * as an `Iterator` of `Result<owned message, ReadError>` (the decoder's
///   [`OwnedDecoder::Owned`]: `Vec<u8>` for lines, `i32` for [`Int32Stream`](crate::adapters::Int32Stream), ...).
///   Recoverable errors (bad bytes, the read timeout) are yielded and the iteration goes
///   on; it ends when the peer closes or after an unrecoverable error.
/// * borrowed straight from the buffer, no copy: [`next_with`](Self::next_with).
///
/// ```
/// use urscript_socket::{adapters::blocking::MessageReader, adapters::Int32Stream, line::LineDecoder};
/// let lines: Vec<Vec<u8>> = MessageReader::new(&b"hello\nworld\n"[..], LineDecoder::new())
///     .collect::<Result<_, _>>()
///     .unwrap();
/// assert_eq!(lines, [b"hello".to_vec(), b"world".to_vec()]);
///
/// let ints = MessageReader::new(&[0u8, 0, 0, 7, 0xFF, 0xFF, 0xFF, 0xFF][..], Int32Stream::new());
/// assert_eq!(ints.map(Result::unwrap).collect::<Vec<i32>>(), [7, -1]);
/// ```
///
/// ```
/// use urscript_socket::{adapters::blocking::MessageReader, line::LineDecoder};
/// let input: &[u8] = b"hello\nworld\n";
/// let mut reader = MessageReader::new(input, LineDecoder::new());
/// let mut lines = Vec::new();
/// while let Some(line) = reader.next_with(|l| l.to_vec()).unwrap() {
///     lines.push(line);
/// }
/// assert_eq!(lines, [b"hello".to_vec(), b"world".to_vec()]);
/// ```
#[derive(Debug)]
pub struct MessageReader<R, D> {
    reader: R,
    decoder: D,
    rx: RecvBuffer<Box<[u8]>>,
    eof: bool,
    /// Set after an unrecoverable error: the iterator is over.
    done: bool,
}

impl<R: Read, D: Decode> MessageReader<R, D> {
    /// A reader with a [`DEFAULT_CAPACITY`] buffer.
    ///
    /// ```
    /// # use urscript_socket::{adapters::blocking::MessageReader, int32::Int32Decoder};
    /// let r = MessageReader::new(&[0u8, 0, 0, 1][..], Int32Decoder::new(1).unwrap());
    /// ```
    pub fn new(reader: R, decoder: D) -> Self {
        Self::with_capacity(reader, decoder, DEFAULT_CAPACITY)
    }

    /// A reader whose buffer holds at most `capacity` bytes: the memory bound.
    ///
    /// ```
    /// # use urscript_socket::{adapters::blocking::MessageReader, line::LineDecoder};
    /// let r = MessageReader::with_capacity(&b""[..], LineDecoder::new(), 8192);
    /// ```
    pub fn with_capacity(reader: R, decoder: D, capacity: usize) -> Self {
        MessageReader {
            reader,
            decoder,
            rx: RecvBuffer::with_capacity(capacity),
            eof: false,
            done: false,
        }
    }

    /// The transport, e.g. to set its read timeout.
    ///
    /// ```
    /// # use urscript_socket::{adapters::blocking::MessageReader, line::LineDecoder};
    /// let mut r = MessageReader::new(&b""[..], LineDecoder::new());
    /// let _inner: &mut &[u8] = r.get_mut();
    /// ```
    pub fn get_mut(&mut self) -> &mut R {
        &mut self.reader
    }

    /// Bytes received but not yet part of a returned message.
    ///
    /// ```
    /// # use urscript_socket::{adapters::blocking::MessageReader, line::LineDecoder};
    /// let mut r = MessageReader::new(&b"a\nrest"[..], LineDecoder::new());
    /// r.next_with(|_| ()).unwrap();
    /// assert_eq!(r.buffered(), b"rest");
    /// ```
    pub fn buffered(&self) -> &[u8] {
        self.rx.data()
    }

    /// Waits for the next message and returns `f(message)`. `Ok(None)`: the peer closed
    /// cleanly between messages. Errors: bad bytes (skipped, so calling again goes on),
    /// a close in the middle of a message, the transport's read timeout, the buffer bound.
    ///
    /// ```
    /// # use urscript_socket::{adapters::blocking::{MessageReader, ReadError}, line::LineDecoder};
    /// let mut r = MessageReader::new(&b"ok\ncut"[..], LineDecoder::new());
    /// assert_eq!(r.next_with(|l| l.to_vec()).unwrap(), Some(b"ok".to_vec()));
    /// assert!(matches!(r.next_with(|l| l.to_vec()), Err(ReadError::Decode(_))));
    /// assert_eq!(r.next_with(|l| l.to_vec()).unwrap(), None);
    /// ```
    pub fn next_with<T>(
        &mut self,
        f: impl FnOnce(D::Item<'_>) -> T,
    ) -> Result<Option<T>, ReadError> {
        loop {
            if self.eof {
                return match self.rx.decode_eof(&mut self.decoder) {
                    Ok(Some(item)) => Ok(Some(f(item))),
                    Ok(None) => Ok(None),
                    Err(e) => Err(ReadError::Decode(e)),
                };
            }
            match self.rx.decode(&mut self.decoder) {
                Ok(Some(item)) => return Ok(Some(f(item))),
                Ok(None) => {}
                Err(e) => return Err(ReadError::Decode(e)),
            }
            let space = self.rx.spare();
            if space.is_empty() {
                return Err(ReadError::BufferFull {
                    capacity: self.rx.capacity(),
                });
            }
            match self.reader.read(space) {
                Ok(0) => self.eof = true,
                Ok(n) => self.rx.commit(n),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                    ) =>
                {
                    return Err(ReadError::TimedOut)
                }
                Err(e) => return Err(ReadError::Io(e)),
            }
        }
    }

    /// Calls `f` for every message, lent from the buffer, until the peer closes; stops at
    /// the first error. (The owned-item form is the `Iterator`.)
    ///
    /// ```
    /// # use urscript_socket::{adapters::blocking::MessageReader, int32::Int32Decoder};
    /// let bytes = [0u8, 0, 0, 1, 0, 0, 0, 2];
    /// let mut sum = 0;
    /// MessageReader::new(&bytes[..], Int32Decoder::new(1).unwrap())
    ///     .for_each_with(|v| sum += v.get(0).unwrap())
    ///     .unwrap();
    /// assert_eq!(sum, 3);
    /// ```
    pub fn for_each_with(&mut self, mut f: impl FnMut(D::Item<'_>)) -> Result<(), ReadError> {
        while self.next_with(&mut f)?.is_some() {}
        Ok(())
    }
}

impl<R: Read, D: OwnedDecoder> MessageReader<R, D> {
    /// Waits for the next message and returns it owned. `Ok(None)`: the peer closed
    /// cleanly between messages. The same as the iterator's `next`, with the error
    /// outside the option.
    ///
    /// ```
    /// # use urscript_socket::{adapters::blocking::MessageReader, var::VarMessageDecoder};
    /// use urscript_socket::adapters::VarRequest;
    /// let mut r = MessageReader::new(&b"SET A 1\n"[..], VarMessageDecoder::new());
    /// assert_eq!(r.next_owned().unwrap(), Some(VarRequest::Set { name: "A".into(), value: 1 }));
    /// assert_eq!(r.next_owned().unwrap(), None);
    /// ```
    pub fn next_owned(&mut self) -> Result<Option<D::Owned>, ReadError> {
        self.next_with(D::to_owned_item)
    }
}

/// Owned messages until the peer closes; recoverable errors (bad bytes, the transport's
/// read timeout) are yielded and the iteration goes on, other errors are yielded once
/// and end it.
///
/// ```
/// use urscript_socket::{adapters::blocking::{MessageReader, ReadError}, line::LineDecoder};
/// let mut r = MessageReader::new(&b"ok\nmuch too long\nok again\ncut"[..], LineDecoder::with_max_len(8));
/// assert_eq!(r.next().unwrap().unwrap(), b"ok");
/// assert!(matches!(r.next(), Some(Err(ReadError::Decode(_)))));   // skipped, goes on
/// assert_eq!(r.next().unwrap().unwrap(), b"ok again");
/// assert!(matches!(r.next(), Some(Err(ReadError::Decode(_)))));   // "cut": no LF before the end
/// assert!(r.next().is_none());
/// ```
impl<R: Read, D: OwnedDecoder> Iterator for MessageReader<R, D> {
    type Item = Result<D::Owned, ReadError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        match self.next_owned() {
            Ok(Some(item)) => Some(Ok(item)),
            Ok(None) => {
                self.done = true;
                None
            }
            Err(e) => {
                self.done = !e.is_recoverable();
                Some(Err(e))
            }
        }
    }
}

/// Writes messages produced by the core encoders to a blocking writer, one `write_all`
/// per message (so a message is never interleaved with another writer's bytes).
///
/// ```
/// use urscript_socket::{adapters::blocking::MessageWriter, ascii_float::encode_float_tuple};
/// let mut w = MessageWriter::new(Vec::new());
/// w.send(|out| encode_float_tuple(&[1.0, 2.5], true, out)).unwrap();
/// assert_eq!(w.get_ref(), b"(1,2.5)\n");
/// ```
#[derive(Debug)]
pub struct MessageWriter<W> {
    writer: W,
    scratch: Vec<u8>,
}

impl<W: Write> MessageWriter<W> {
    /// Wraps `writer`.
    ///
    /// ```
    /// # use urscript_socket::adapters::blocking::MessageWriter;
    /// let w = MessageWriter::new(Vec::new());
    /// ```
    pub fn new(writer: W) -> Self {
        MessageWriter {
            writer,
            scratch: Vec::new(),
        }
    }

    /// The writer.
    ///
    /// ```
    /// # use urscript_socket::adapters::blocking::MessageWriter;
    /// assert!(MessageWriter::new(Vec::new()).get_ref().is_empty());
    /// ```
    pub fn get_ref(&self) -> &W {
        &self.writer
    }

    /// The writer, mutably.
    ///
    /// ```
    /// # use urscript_socket::adapters::blocking::MessageWriter;
    /// MessageWriter::new(Vec::new()).get_mut().push(1);
    /// ```
    pub fn get_mut(&mut self) -> &mut W {
        &mut self.writer
    }

    /// Encodes one message with `encode` (any core encoder) and writes it whole. If the
    /// encoder refuses, nothing is written.
    ///
    /// ```
    /// # use urscript_socket::adapters::blocking::MessageWriter;
    /// use urscript_socket::int32::encode_int32_list;
    /// let mut w = MessageWriter::new(Vec::new());
    /// w.send(|out| encode_int32_list(&[1, 2], out)).unwrap();
    /// assert_eq!(w.get_ref().len(), 8);
    /// ```
    pub fn send(
        &mut self,
        encode: impl FnOnce(&mut Vec<u8>) -> Result<usize, EncodeError>,
    ) -> Result<(), WriteError> {
        self.scratch.clear();
        encode(&mut self.scratch)?;
        self.writer.write_all(&self.scratch)?;
        self.writer.flush()?;
        Ok(())
    }
}
