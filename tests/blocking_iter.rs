//! The blocking adapter over 127.0.0.1: owned messages as an `Iterator`, recoverable
//! errors yielded and skipped, `next_with` still lending from the buffer, and both error
//! types converting into `std::io::Error`.

use std::io::{self, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::time::Duration;

use urscript_socket::adapters::blocking::{MessageReader, MessageWriter, ReadError, WriteError};
use urscript_socket::adapters::{Int32Stream, VarRequest};
use urscript_socket::ascii_float::encode_float_tuple;
use urscript_socket::line::LineDecoder;
use urscript_socket::var::VarMessageDecoder;
use urscript_socket::EncodeError;

/// A server written with the iterator, answering "shoot" with a tuple; returns what the
/// robot side received.
#[test]
fn iterator_server_survives_an_over_long_line() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    let server = std::thread::spawn(move || -> io::Result<usize> {
        let (robot, _) = listener.accept()?;
        let mut replies = MessageWriter::new(robot.try_clone()?);
        let mut skipped = 0;
        for request in MessageReader::new(robot, LineDecoder::with_max_len(64)) {
            match request {
                Ok(line) if line == b"shoot" => {
                    replies.send(|out| encode_float_tuple(&[1.0, 2.0], false, out))?
                }
                Ok(_) => {}
                Err(e) if e.is_recoverable() => skipped += 1,
                Err(e) => return Err(e.into()),
            }
        }
        Ok(skipped)
    });
    let mut robot = TcpStream::connect(addr).unwrap();
    robot
        .set_read_timeout(Some(Duration::from_secs(5)))
        .unwrap();
    let mut reply = [0u8; 5];
    for _ in 0..3 {
        robot.write_all(&[b'z'; 1000]).unwrap();
        robot.write_all(b"\nshoot\n").unwrap();
        robot.read_exact(&mut reply).unwrap();
        assert_eq!(&reply, b"(1,2)");
    }
    drop(robot);
    assert_eq!(server.join().unwrap().unwrap(), 3);
}

#[test]
fn owned_items_and_lent_items_on_one_reader() {
    let input: &[u8] = b"SET A 1\nGET A\nSET B oops\nGET B\n";
    let mut r = MessageReader::new(input, VarMessageDecoder::new());
    // Lent from the buffer, no copy.
    let name_len = r.next_with(|m| m.to_owned_name_len()).unwrap();
    assert_eq!(name_len, Some(1));
    // Owned, through the iterator.
    let rest: Vec<_> = r.by_ref().collect();
    assert_eq!(rest.len(), 3);
    assert_eq!(
        rest[0].as_ref().unwrap(),
        &VarRequest::Get { name: "A".into() }
    );
    assert!(matches!(rest[1], Err(ReadError::Decode(_))));
    assert_eq!(
        rest[2].as_ref().unwrap(),
        &VarRequest::Get { name: "B".into() }
    );
    assert!(r.next().is_none());
}

trait NameLen {
    fn to_owned_name_len(&self) -> usize;
}
impl NameLen for urscript_socket::var::VarMessage<'_> {
    fn to_owned_name_len(&self) -> usize {
        match self {
            urscript_socket::var::VarMessage::Set { name, .. }
            | urscript_socket::var::VarMessage::Get { name } => name.len(),
        }
    }
}

#[test]
fn iterator_ends_after_an_unrecoverable_error() {
    struct Broken;
    impl Read for Broken {
        fn read(&mut self, _: &mut [u8]) -> io::Result<usize> {
            Err(io::Error::new(io::ErrorKind::ConnectionReset, "reset"))
        }
    }
    let mut r = MessageReader::new(Broken, Int32Stream::new());
    assert!(matches!(r.next(), Some(Err(ReadError::Io(_)))));
    assert!(r.next().is_none());
}

#[test]
fn read_timeouts_are_yielded_and_the_iteration_goes_on() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let mut robot = TcpStream::connect(listener.local_addr().unwrap()).unwrap();
    let (server, _) = listener.accept().unwrap();
    server
        .set_read_timeout(Some(Duration::from_millis(20)))
        .unwrap();
    let mut ints = MessageReader::new(server, Int32Stream::new());
    assert!(matches!(ints.next(), Some(Err(ReadError::TimedOut))));
    robot.write_all(&42i32.to_be_bytes()).unwrap();
    assert_eq!(ints.next().unwrap().unwrap(), 42);
}

#[test]
fn errors_convert_into_io_errors() {
    fn reply() -> io::Result<()> {
        let mut w = MessageWriter::new(Vec::new());
        w.send(|out| encode_float_tuple(&[], false, out))?; // refused: no values
        Ok(())
    }
    assert_eq!(reply().unwrap_err().kind(), io::ErrorKind::InvalidInput);

    fn read() -> io::Result<Vec<u8>> {
        let mut r = MessageReader::new(&b"cut"[..], LineDecoder::with_max_len(2));
        Ok(r.next().unwrap()?)
    }
    assert_eq!(read().unwrap_err().kind(), io::ErrorKind::InvalidData);

    let e: io::Error = WriteError::Io(io::Error::new(io::ErrorKind::BrokenPipe, "x")).into();
    assert_eq!(e.kind(), io::ErrorKind::BrokenPipe);
    let e: io::Error = ReadError::Io(io::Error::new(io::ErrorKind::BrokenPipe, "x")).into();
    assert_eq!(e.kind(), io::ErrorKind::BrokenPipe);
    let w = WriteError::from(EncodeError::NoValues);
    assert!(w.to_string().contains("cannot encode"));
}
