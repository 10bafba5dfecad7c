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
    let text =
        std::fs::read_to_string(path).map_err(|e| format!("--rules {}: {e}", path.display()))?;
    parse(&text).map_err(|e| format!("--rules {}: {e}", path.display()))
}

pub fn parse(text: &str) -> Result<Vec<Rule>, String> {
    let mut rules = Vec::new();
    for (i, line) in text.lines().enumerate() {
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
    use super::glob;

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
