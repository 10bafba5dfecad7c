#![no_main]
use libfuzzer_sys::fuzz_target;
use urscript_socket::var::VarReplyDecoder;

// The hand-written second reading of the grammar that tests/var_grammar.rs also uses.
#[path = "../../tests/var_grammar/oracle.rs"]
mod oracle;

fuzz_target!(|data: &[u8]| {
    urscript_socket_fuzz::check_split(|| VarReplyDecoder::new("POS_X").unwrap(), data, urscript_socket::var::DEFAULT_MAX_VAR_LINE_LEN + 1);
    // Every whole line (up to the decoder's bound): the decoder and the oracle agree on
    // the value or on the error (kind, offset).
    let mut lines: Vec<&[u8]> = data.split(|&b| b == b'\n').collect();
    lines.pop(); // the part after the last LF is not a line
    for line in lines {
        if line.len() > urscript_socket::var::DEFAULT_MAX_VAR_LINE_LEN {
            continue;
        }
        let mut framed = line.to_vec();
        framed.push(b'\n');
        let ours = match VarReplyDecoder::new("POS_X").unwrap().decode(&framed) {
            Ok(s) => s.item().ok_or((urscript_socket::ErrorKind::Truncated, usize::MAX)),
            Err(e) => Err((e.kind(), e.offset() as usize)),
        };
        let bare = line.strip_suffix(b"\r").unwrap_or(line);
        assert_eq!(ours, oracle::var_reply(bare, b"POS_X"), "{line:?}");
    }
});
