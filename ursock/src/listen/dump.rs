//! Bytes for people: hex and text side by side, wrapped with offsets when long.

use std::fmt::Write as _;

use crate::show::quoted;

/// Bytes shown on one row of the wrapped dump.
pub const ROW: usize = 16;

/// A chunk: `68 69  "hi"` on one line when short, otherwise a header and the rows of
/// [`crate::show::hex_dump`] (`0010  ...  |text|`) followed by the text when it is valid UTF-8.
/// Every line but the first starts with `indent`.
pub fn chunk(bytes: &[u8], indent: &str, max: usize) -> String {
    let all = bytes;
    let bytes = &bytes[..bytes.len().min(max.max(ROW))];
    if all.len() <= ROW {
        return format!("{}  {}", crate::show::hex(bytes), quoted(bytes));
    }
    let mut s = format!("({} bytes)", all.len());
    for row in crate::show::hex_dump(bytes) {
        let _ = write!(s, "\n{indent}{row}");
    }
    if bytes.len() < all.len() {
        let _ = write!(
            s,
            "\n{indent}... {} more bytes not shown (--show-max {max})",
            all.len() - bytes.len()
        );
    } else if !bytes.is_ascii() && std::str::from_utf8(bytes).is_ok() {
        let _ = write!(s, "\n{indent}text {}", quoted(bytes));
    }
    s
}
