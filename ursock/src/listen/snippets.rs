//! `--snippets FILE`: named replies the operator sends with `$NAME` or `$N` (and, in the
//! terminal UI, with F2..F9 for the first eight).
//!
//! The format is a line format (no TOML crate is in the tree, and a reply spec is one
//! line anyway), one snippet a line:
//!
//! ```text
//! # comment lines and blank lines are skipped
//! pose = floats 0.4 -0.2 0.3
//! ack  = text OK\r\n
//! stop = hex 02 53 03
//! ```
//!
//! `NAME = REPLY-SPEC`: NAME is 1 to [`MAX_NAME`] of `A-Z a-z 0-9 _ - .`, not all digits
//! (`$3` means the third snippet); the spec is everything after `=` and the blanks that
//! follow it, to the end of the line (trailing blanks are part of it: `line a ` sends the
//! space). Every spec is checked at start, so a typo is an error naming its line, never a
//! surprise when the key is pressed.

use std::io::Read;
use std::path::Path;

use super::spec::{self, Reply};

/// Snippets in one file.
pub const MAX_SNIPPETS: usize = 256;
/// Bytes of a snippet's name.
pub const MAX_NAME: usize = 64;
/// Bytes of the file read (a larger file is refused, not cut).
pub const MAX_FILE: u64 = 1024 * 1024;

/// One named reply.
#[derive(Clone, Debug)]
pub struct Snippet {
    pub name: String,
    /// The spec as written in the file.
    pub spec: String,
    pub reply: Reply,
    /// Its line in the file (1-based).
    pub line: usize,
}

pub fn load(path: &Path) -> Result<Vec<Snippet>, String> {
    let what = format!("--snippets {}", path.display());
    let file = std::fs::File::open(path).map_err(|e| format!("{what}: {e}"))?;
    let mut bytes = Vec::new();
    file.take(MAX_FILE + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| format!("{what}: {e}"))?;
    if bytes.len() as u64 > MAX_FILE {
        return Err(format!("{what}: larger than {MAX_FILE} bytes"));
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        format!("{what}: line {line}: not UTF-8 (write a raw byte as `text \\xHH` or `hex HH`)")
    })?;
    parse(&text).map_err(|e| format!("{what}: {e}"))
}

/// The snippets of a file's text; an error names the line.
pub fn parse(text: &str) -> Result<Vec<Snippet>, String> {
    let mut out: Vec<Snippet> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let raw = raw.strip_suffix('\r').unwrap_or(raw);
        let trimmed = raw.trim_start();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let Some((name, spec_text)) = trimmed.split_once('=') else {
            return Err(format!(
                "line {line}: expected `NAME = REPLY-SPEC`, e.g. `pose = floats 1 2 3`"
            ));
        };
        let name = name.trim_end();
        check_name(name).map_err(|e| format!("line {line}: {e}"))?;
        if let Some(first) = out.iter().find(|s| s.name == name) {
            return Err(format!(
                "line {line}: snippet {name:?} is already defined on line {}",
                first.line
            ));
        }
        if out.len() >= MAX_SNIPPETS {
            return Err(format!(
                "line {line}: more than {MAX_SNIPPETS} snippets in one file"
            ));
        }
        let spec_text = spec_text.trim_start();
        let reply = spec::parse(spec_text).map_err(|e| format!("line {line} ({name}): {e}"))?;
        out.push(Snippet {
            name: name.to_string(),
            spec: spec_text.to_string(),
            reply,
            line,
        });
    }
    Ok(out)
}

fn check_name(name: &str) -> Result<(), String> {
    if name.is_empty() {
        return Err("a snippet needs a name before `=`".into());
    }
    if name.len() > MAX_NAME {
        return Err(format!("a name longer than {MAX_NAME} bytes"));
    }
    if let Some(c) = name
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.')))
    {
        return Err(format!(
            "name {name:?}: {c:?} is not allowed (letters, digits, _ - .)"
        ));
    }
    if name.bytes().all(|b| b.is_ascii_digit()) {
        return Err(format!(
            "name {name:?}: all digits (`${name}` means the snippet numbered {name})"
        ));
    }
    Ok(())
}

/// `$KEY`: the snippet numbered KEY (1-based, in file order) or named KEY.
pub fn find<'a>(snippets: &'a [Snippet], key: &str) -> Result<&'a Snippet, String> {
    if snippets.is_empty() {
        return Err(format!(
            "${key}: no snippets loaded (start with --snippets FILE)"
        ));
    }
    let found = match key.parse::<usize>() {
        Ok(n) => n.checked_sub(1).and_then(|i| snippets.get(i)),
        Err(_) => snippets.iter().find(|s| s.name == key),
    };
    found.ok_or_else(|| {
        format!(
            "${key}: no such snippet (1..{} or a name; `snippets` lists them)",
            snippets.len()
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_of_snippets_is_read_in_order() {
        let s =
            parse("# camera\n\npose = floats 0.4 -0.2 0.3\r\n  ack=text OK\\r\\n\nsp = line a \n")
                .unwrap();
        let names: Vec<&str> = s.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["pose", "ack", "sp"]);
        assert_eq!(s[0].reply.bytes, b"(0.4,-0.2,0.3)");
        assert_eq!(s[0].line, 3);
        assert_eq!(s[1].reply.bytes, b"OK\r\n");
        assert_eq!(s[2].reply.bytes, b"a \n", "trailing blanks are kept");
        assert_eq!(find(&s, "2").unwrap().name, "ack");
        assert_eq!(find(&s, "sp").unwrap().line, 5);
        assert!(find(&s, "0").unwrap_err().contains("1..3"));
        assert!(find(&s, "4").is_err());
        assert!(find(&s, "nope").unwrap_err().contains("no such snippet"));
        assert!(find(&[], "1").unwrap_err().contains("--snippets"));
    }

    #[test]
    fn a_bad_line_is_an_error_naming_it() {
        for (text, want) in [
            (
                "a = line x\nno equals sign\n",
                "line 2: expected `NAME = REPLY-SPEC`",
            ),
            ("= line x\n", "line 1: a snippet needs a name"),
            ("a b = line x\n", "' ' is not allowed"),
            ("12 = line x\n", "all digits"),
            (
                "a = line x\n\na = line y\n",
                "line 3: snippet \"a\" is already defined on line 1",
            ),
            (
                "a = floatz 1\n",
                "line 1 (a): unknown reply format \"floatz\"",
            ),
            ("a = hex 0g\n", "line 1 (a): hex"),
        ] {
            let e = parse(text).unwrap_err();
            assert!(e.contains(want), "{text:?}: {e}");
        }
        let long = format!("{} = line x\n", "n".repeat(MAX_NAME + 1));
        assert!(parse(&long).unwrap_err().contains("longer than"));
        let many: String = (0..=MAX_SNIPPETS)
            .map(|i| format!("s{i} = line {i}\n"))
            .collect();
        assert!(parse(&many)
            .unwrap_err()
            .contains(&format!("line {}: more than", MAX_SNIPPETS + 1)));
    }
}
