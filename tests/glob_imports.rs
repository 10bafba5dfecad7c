//! The crate's root names glob-import next to tokio-util's without an ambiguity: the
//! core decoder type is `FrameDecoder`, so `Framed` below is tokio-util's. Compiling this
//! file is the proof (`ambiguous_glob_imports` is denied); the test also runs a round trip.
#![deny(ambiguous_glob_imports)]

use futures_util::SinkExt;
use tokio_util::codec::*;
use urscript_socket::adapters::tokio_codec::*;
use urscript_socket::*;

#[tokio::test]
async fn tokio_utils_framed_under_both_globs() {
    let (a, mut b) = tokio::io::duplex(64);
    // tokio_util::codec::Framed, not ours; `Bytes` is the tokio_codec re-export.
    let mut framed: Framed<_, LineCodec> = Framed::new(a, LineCodec::new());
    framed.send(Bytes::from_static(b"shoot")).await.unwrap();
    drop(framed);
    let mut got = Vec::new();
    tokio::io::AsyncReadExt::read_to_end(&mut b, &mut got)
        .await
        .unwrap();
    assert_eq!(got, b"shoot\n");
    // And ours, by its new name, from the root glob.
    let mut d: FrameDecoder<line::Line> = line::LineDecoder::new();
    assert_eq!(
        d.decode(b"a\n").unwrap(),
        Status::Complete {
            item: &b"a"[..],
            consumed: 2,
            at: 0
        }
    );
}
