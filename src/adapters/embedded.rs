//! Adapters over `embedded_io_async::{Read, Write}`: embassy-net's `TcpSocket`, or any
//! smoltcp-based stack. No allocator: the buffer is a `[u8; N]` owned by the reader.

use embedded_io_async::{Read, Write};

use crate::adapters::OwnedDecoder;
use crate::{Decode, EncodeError, RecvBuffer, SliceSink};

/// Why an embedded read or write failed: the adapters' shared error, over the socket's
/// error type.
///
/// ```
/// use urscript_socket::adapters::embedded::AdapterError;
/// let e: AdapterError<core::convert::Infallible> = AdapterError::BufferFull { capacity: 256 };
/// assert_eq!(format!("{e}"), "receive buffer of 256 bytes full without a complete message");
/// ```
pub use crate::adapters::AdapterError;

/// Reads messages of one format from an `embedded_io_async::Read`, through a core decoder
/// over an `N`-byte buffer (the memory bound).
///
/// ```
/// # tokio::runtime::Builder::new_current_thread().build().unwrap().block_on(async {
/// use urscript_socket::adapters::{embedded::MessageReader, Int32Stream};
/// let input: &[u8] = &[0, 0, 0, 7, 0xFF, 0xFF, 0xFF, 0xFF];
/// let mut r: MessageReader<_, _, 64> = MessageReader::new(input, Int32Stream::new());
/// assert_eq!(r.next_owned().await.unwrap(), Some(7));
/// assert_eq!(r.next_owned().await.unwrap(), Some(-1));
/// assert_eq!(r.next_owned().await.unwrap(), None);
/// # });
/// ```
#[derive(Debug)]
pub struct MessageReader<R, D, const N: usize> {
    reader: R,
    decoder: D,
    rx: RecvBuffer<[u8; N]>,
    eof: bool,
}

impl<R: Read, D: Decode, const N: usize> MessageReader<R, D, N> {
    /// Wraps `reader`; the buffer is `N` bytes inside the value.
    ///
    /// ```
    /// # use urscript_socket::{adapters::embedded::MessageReader, line::LineDecoder};
    /// let r: MessageReader<&[u8], _, 256> = MessageReader::new(&b""[..], LineDecoder::new());
    /// ```
    pub fn new(reader: R, decoder: D) -> Self {
        MessageReader {
            reader,
            decoder,
            rx: RecvBuffer::new(),
            eof: false,
        }
    }

    /// The transport, e.g. to write a reply on the same socket with [`send`].
    ///
    /// ```
    /// # use urscript_socket::{adapters::embedded::MessageReader, line::LineDecoder};
    /// let mut r: MessageReader<&[u8], _, 16> = MessageReader::new(&b""[..], LineDecoder::new());
    /// let _transport: &mut &[u8] = r.get_mut();
    /// ```
    pub fn get_mut(&mut self) -> &mut R {
        &mut self.reader
    }

    /// Waits for the next message and returns `f(message)`; `Ok(None)` once the peer
    /// closed cleanly between messages.
    ///
    /// ```
    /// # tokio::runtime::Builder::new_current_thread().build().unwrap().block_on(async {
    /// # use urscript_socket::{adapters::embedded::MessageReader, line::LineDecoder};
    /// let mut r: MessageReader<_, _, 64> = MessageReader::new(&b"hi\n"[..], LineDecoder::new());
    /// assert_eq!(r.next_with(|l| l.len()).await.unwrap(), Some(2));
    /// # });
    /// ```
    pub async fn next_with<T>(
        &mut self,
        f: impl FnOnce(D::Item<'_>) -> T,
    ) -> Result<Option<T>, AdapterError<R::Error>> {
        loop {
            if self.eof {
                return match self.rx.decode_eof(&mut self.decoder) {
                    Ok(Some(item)) => Ok(Some(f(item))),
                    Ok(None) => Ok(None),
                    Err(e) => Err(AdapterError::Decode(e)),
                };
            }
            match self.rx.decode(&mut self.decoder) {
                Ok(Some(item)) => return Ok(Some(f(item))),
                Ok(None) => {}
                Err(e) => return Err(AdapterError::Decode(e)),
            }
            let space = self.rx.spare();
            if space.is_empty() {
                return Err(AdapterError::BufferFull { capacity: N });
            }
            match self.reader.read(space).await {
                Ok(0) => self.eof = true,
                Ok(n) => self.rx.commit(n),
                Err(e) => return Err(AdapterError::Io(e)),
            }
        }
    }
}

impl<R: Read, D: OwnedDecoder, const N: usize> MessageReader<R, D, N> {
    /// Waits for the next message and returns it owned (an `i32` from
    /// [`Int32Stream`](crate::adapters::Int32Stream), a `FloatTuple`, ...; with `alloc`
    /// also `Vec<u8>` lines); `Ok(None)` once the peer closed cleanly between messages.
    ///
    /// ```
    /// # tokio::runtime::Builder::new_current_thread().build().unwrap().block_on(async {
    /// use urscript_socket::adapters::{embedded::MessageReader, ByteStream};
    /// let mut r: MessageReader<_, _, 16> = MessageReader::new(&[2u8, 3][..], ByteStream::new());
    /// assert_eq!(r.next_owned().await.unwrap(), Some(2));
    /// # });
    /// ```
    pub async fn next_owned(&mut self) -> Result<Option<D::Owned>, AdapterError<R::Error>> {
        self.next_with(D::to_owned_item).await
    }
}

/// Encodes one message into `scratch` with `encode` (any core encoder) and writes it all
/// to `writer`. Nothing is written if the encoder refuses or `scratch` is too small.
///
/// ```
/// # tokio::runtime::Builder::new_current_thread().build().unwrap().block_on(async {
/// use urscript_socket::{adapters::embedded::send, int32::encode_int32};
/// let mut out = [0u8; 8];
/// let mut scratch = [0u8; 16];
/// let mut w: &mut [u8] = &mut out;
/// send(&mut w, &mut scratch, |sink| encode_int32(100, sink)).await.unwrap();
/// assert_eq!(out[..4], [0, 0, 0, 100]);
/// # });
/// ```
pub async fn send<W: Write>(
    writer: &mut W,
    scratch: &mut [u8],
    encode: impl FnOnce(&mut SliceSink<'_>) -> Result<usize, EncodeError>,
) -> Result<(), AdapterError<W::Error>> {
    let mut sink = SliceSink::new(scratch);
    encode(&mut sink).map_err(AdapterError::Encode)?;
    writer
        .write_all(sink.written())
        .await
        .map_err(AdapterError::Io)
}
