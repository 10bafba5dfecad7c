//! `--rules FILE`: canned replies, to emulate a camera or gripper without code.
//!
//! One rule a line, `PATTERN => REPLY`; `#` starts a comment line. PATTERN is matched
//! against the whole decoded message (a line's text without its LF, an int as decimal);
//! `*` matches any run of characters and `?` one character; nothing else is special.
//! REPLY is a reply spec (`floats 0.1 0.2 0.3`, `line OK`, `hex 06`...). The first rule
//! that matches wins; no match falls back to `--reply`.
//!
//! ```text
//! # camera
//! trigger      => floats 0.12 -0.05 0.3 0 0 1.57
//! status       => line READY
//! job *        => line OK
//! ```

use super::spec::{self, Reply};

pub struct Rule {
    pub pattern: String,
    pub reply: Reply,
    pub line: usize,
}

pub fn load(path: &std::path::Path) -> Result<Vec<Rule>, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("--rules {}: {e}", path.display()))?;
    let text = text_of(&bytes).map_err(|e| format!("--rules {}: {e}", path.display()))?;
    parse(text).map_err(|e| format!("--rules {}: {e}", path.display()))
}

/// The file as text; if it is not UTF-8, where the first bad byte is (line, column).
fn text_of(bytes: &[u8]) -> Result<&str, String> {
    std::str::from_utf8(bytes).map_err(|e| {
        let at = e.valid_up_to();
        let before = &bytes[..at];
        let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
        let col = at - before.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1) + 1;
        format!(
            "line {line}, column {col}: not UTF-8 (byte 0x{:02X}); write the bytes of a reply as hex",
            bytes[at]
        )
    })
}

pub fn parse(text: &str) -> Result<Vec<Rule>, String> {
    let mut rules = Vec::new();
    // Lines end with LF, CR LF or CR alone.
    let text = text.replace("\r\n", "\n");
    for (i, line) in text.split(['\n', '\r']).enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let (pattern, reply) = t
            .split_once("=>")
            .ok_or_else(|| format!("line {}: expected `PATTERN => REPLY`", i + 1))?;
        let reply = spec::parse(reply.trim()).map_err(|e| format!("line {}: {e}", i + 1))?;
        rules.push(Rule {
            pattern: pattern.trim().to_string(),
            reply,
            line: i + 1,
        });
    }
    Ok(rules)
}

pub fn find<'r>(rules: &'r [Rule], message: &[u8]) -> Option<&'r Rule> {
    rules.iter().find(|r| glob(r.pattern.as_bytes(), message))
}

/// `*` any run, `?` one byte; iterative with one backtrack point (linear in practice).
pub fn glob(p: &[u8], s: &[u8]) -> bool {
    let (mut pi, mut si) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while si < s.len() {
        match p.get(pi) {
            Some(b'*') => {
                star = Some((pi, si));
                pi += 1;
            }
            Some(&c) if c == b'?' || c == s[si] => {
                pi += 1;
                si += 1;
            }
            _ => match star {
                Some((sp, ss)) => {
                    pi = sp + 1;
                    si = ss + 1;
                    star = Some((sp, ss + 1));
                }
                None => return false,
            },
        }
    }
    p[pi.min(p.len())..].iter().all(|&c| c == b'*')
}

#[cfg(test)]
mod tests {
    use super::{glob, parse, text_of};

    #[test]
    fn rules_files_name_their_lines_whatever_ends_them() {
        let e = text_of(b"a => line x\nb => line \xE9\n")
            .err()
            .unwrap_or_default();
        assert!(
            e.starts_with("line 2, column 11: not UTF-8 (byte 0xE9)"),
            "{e}"
        );
        for text in [
            "a => line x\r\nbad\r\n",
            "a => line x\rbad\r",
            "a => line x\nbad\n",
        ] {
            let e = parse(text).err().unwrap_or_default();
            assert!(e.starts_with("line 2:"), "{text:?}: {e}");
        }
        assert_eq!(parse("a => line x\r\nb => line y\r\n").unwrap().len(), 2);
    }

    #[test]
    fn globs() {
        assert!(glob(b"job *", b"job 12"));
        assert!(glob(b"trigger", b"trigger"));
        assert!(!glob(b"trigger", b"trigger2"));
        assert!(glob(b"t?g*r", b"tagger"));
        assert!(glob(b"*", b""));
        assert!(!glob(b"a*b", b"acc"));
    }
}
