#![no_main]
use libfuzzer_sys::fuzz_target;
use urscript_socket::var::{parse_var_message, VarMessage, VarMessageDecoder};

// The hand-written second reading of the grammar that tests/var_grammar.rs also uses.
#[path = "../../tests/var_grammar/oracle.rs"]
mod oracle;

fuzz_target!(|data: &[u8]| {
    urscript_socket_fuzz::check_split(VarMessageDecoder::new, data, urscript_socket::var::DEFAULT_MAX_VAR_LINE_LEN + 1);
    // Every line: the nom parser and the oracle give the same message or the same error
    // (kind, offset).
    for line in data.split(|&b| b == b'\n') {
        let ours = parse_var_message(line).map(|m| match m {
            VarMessage::Set { name, value } => (true, name.as_bytes(), Some(value)),
            VarMessage::Get { name } => (false, name.as_bytes(), None),
        });
        assert_eq!(ours, oracle::var_message(line), "{line:?}");
    }
});
