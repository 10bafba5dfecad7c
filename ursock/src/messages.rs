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
            "the {} value (index {index}) is NaN or infinite and has no plain decimal form",
            ordinal(index + 1)
        ),
        EncodeError::ForbiddenByte { byte, index } => format!(
            "byte 0x{byte:02X}, the {} byte (index {index}), would break the framing",
            ordinal(index + 1)
        ),
        other => other.to_string(),
    }
}

/// `1st`, `2nd`, `3rd`, `4th`, `11th`, `21st`...
fn ordinal(n: usize) -> String {
    let suffix = match (n % 10, n % 100) {
        (_, 11..=13) => "th",
        (1, _) => "st",
        (2, _) => "nd",
        (3, _) => "rd",
        _ => "th",
    };
    format!("{n}{suffix}")
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
        assert!(m.starts_with("the 1st value (index 0)"), "{m}");
        assert_eq!(ordinal(12), "12th");
        assert_eq!(ordinal(22), "22nd");
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
