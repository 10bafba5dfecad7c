//! The library's errors in the words of the command the user typed.
//!
//! The library's `Display` texts are written for API users ("value 0 is NaN", "3 values
//! where 6 were asked for"); at the command line an index reads as a value, and nobody
//! asked for 6 values when they typed a pose. These functions reword the few that mislead
//! and pass the others through.

use urscript_socket::{DecodeError, EncodeError, ErrorKind};

/// An encoder's refusal, for `encode` and `robot`.
pub fn encode_error(e: EncodeError) -> String {
    match e {
        EncodeError::NotFinite { index } => format!(
            "the value at index {index} (counting from 0) is NaN or infinite and has no \
             plain decimal form"
        ),
        EncodeError::ForbiddenByte { byte, index } => {
            format!("byte 0x{byte:02X} at index {index} (counting from 0) would break the framing")
        }
        other => other.to_string(),
    }
}

/// A parse error of a value's text (`p[...]`, `[...]`, a number): the CLI's wording.
/// `offset` counting is the library's (absolute in a stream).
pub fn value_error(e: &DecodeError) -> String {
    let at = e.offset();
    match e.kind() {
        ErrorKind::TooFewValues { found, wanted } => {
            format!("a pose p[...] holds {wanted} values, this one holds {found} (at byte {at})")
        }
        ErrorKind::UnexpectedByte { expected, .. } if expected.starts_with("']'") => {
            format!("input ended before ']' closing the list (the text ends at byte {at})")
        }
        _ => e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use urscript_socket::to_str::parse_value;

    #[test]
    fn an_index_is_called_an_index() {
        let m = encode_error(EncodeError::NotFinite { index: 0 });
        assert!(m.starts_with("the value at index 0"), "{m}");
    }

    #[test]
    fn a_short_pose_is_not_a_request() {
        let e = parse_value(b"p[1,2,3]").unwrap_err();
        let m = value_error(&e);
        assert!(m.contains("pose") && !m.contains("asked"), "{m}");
    }

    #[test]
    fn an_unclosed_list_says_the_input_ended() {
        let e = parse_value(b"[1, 2").unwrap_err();
        let m = value_error(&e);
        assert!(m.starts_with("input ended before ']'"), "{m}");
    }
}
