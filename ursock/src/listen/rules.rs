//! `--rules FILE`: canned replies, to emulate a camera or gripper without code.
//!
//! One rule a line, `PATTERN => REPLY`; `#` starts a comment line. PATTERN is matched
//! against the whole decoded message (a line's text without its LF, an int as decimal);
//! `*` matches any run of characters and `?` one character (a byte that is not UTF-8
//! counts as one); nothing else is special, and there is no escape.
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

/// The largest rules file `load` reads: 1 MiB, room for thousands of rules. A larger file
/// is refused rather than read whole. It also bounds the matching work per message: at
/// most (the patterns' total length) × (the message's length) steps, see [`glob`].
pub const MAX_RULES_FILE: u64 = 1 << 20;

pub fn load(path: &std::path::Path) -> Result<Vec<Rule>, String> {
    use std::io::Read as _;
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_RULES_FILE + 1).read_to_end(&mut bytes))
        .map_err(|e| format!("--rules {}: {e}", path.display()))?;
    if bytes.len() as u64 > MAX_RULES_FILE {
        return Err(format!(
            "--rules {}: larger than {MAX_RULES_FILE} bytes (1 MiB), the most a rules file may hold",
            path.display()
        ));
    }
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
    rules.iter().find(|r| glob(&r.pattern, message))
}

// Why this matcher is ours and not a crate's. `wildmatch`
// has exactly these semantics (`*`, `?`, nothing else special, no escapes) but matches
// `&str`, and a message is bytes that need not be UTF-8: a line with a stray 0xE9 must
// still match `*` or `err*`, and a lossy conversion would turn every bad byte into
// U+FFFD (so a pattern could name bytes that were never sent). `globset` compiles to a
// regex (regex-automata, a large dependency), makes `[`, `{` and `\` special and is
// built for paths; a rule file written for "only `*` and `?` are special" would change
// meaning. What is left is the classic one-backtrack-point wildcard loop, about twenty
// lines. The property tests below hold it to two oracles: `wildmatch` itself on UTF-8
// text, and a dynamic-programming matcher (the definition, written out) on any bytes.

/// Whether `message` matches `pattern`: `*` matches any run of characters (also none),
/// `?` exactly one character, any other character itself. A character is a UTF-8
/// encoded one; a byte of `message` that is not part of a valid UTF-8 character counts as
/// one character by itself (so `?` matches a lone 0xE9, and `caf?` matches `café`).
///
/// Iterative, with one backtrack point (the last `*`): time at most
/// O(`pattern.len()` × `message.len()`), no recursion, no allocation. Both are bounded by
/// the caller: a pattern is one line of the rules file, a message one decoded message
/// (at most the listener's frame bound).
pub fn glob(pattern: &str, message: &[u8]) -> bool {
    let (p, s) = (pattern.as_bytes(), message);
    let (mut pi, mut si) = (0, 0);
    // Where to resume after the last `*`: (its index in p, the message index it is at).
    let mut star: Option<(usize, usize)> = None;
    while si < s.len() {
        let su = unit_len(s, si);
        let matched = match p.get(pi) {
            Some(b'*') => {
                star = Some((pi, si));
                pi += 1;
                continue;
            }
            Some(b'?') => Some(1),
            Some(_) => {
                let pu = unit_len(p, pi);
                (p[pi..pi + pu] == s[si..si + su]).then_some(pu)
            }
            None => None,
        };
        match (matched, star) {
            (Some(pu), _) => {
                pi += pu;
                si += su;
            }
            (None, Some((sp, ss))) => {
                // Let the last `*` swallow one more character and try again after it.
                let next = ss + unit_len(s, ss);
                star = Some((sp, next));
                pi = sp + 1;
                si = next;
            }
            (None, None) => return false,
        }
    }
    p[pi.min(p.len())..].iter().all(|&c| c == b'*')
}

/// The length of the character at `s[i]` (`i < s.len()`): that of a valid UTF-8
/// encoded character starting there, else 1 (a byte that is not UTF-8 on its own).
fn unit_len(s: &[u8], i: usize) -> usize {
    let want = match s[i] {
        0xC2..=0xDF => 2,
        0xE0..=0xEF => 3,
        0xF0..=0xF4 => 4,
        _ => return 1,
    };
    match s.get(i..i + want) {
        Some(c) if std::str::from_utf8(c).is_ok() => want,
        _ => 1,
    }
}

#[cfg(test)]
mod tests {
    use super::{glob, load, parse, text_of, MAX_RULES_FILE};
    use proptest::prelude::*;

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
    fn a_rules_file_is_read_up_to_its_bound() {
        let dir = std::env::temp_dir().join(format!("ursock-rules-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("rules.txt");
        // Exactly at the bound: read (a comment line filling it, then one rule).
        let rule = "a => line x\n";
        let fill = usize::try_from(MAX_RULES_FILE).unwrap() - rule.len() - 1;
        let mut text = format!("#{}\n{rule}", "c".repeat(fill - 1));
        assert_eq!(text.len() as u64, MAX_RULES_FILE);
        std::fs::write(&path, &text).unwrap();
        assert_eq!(load(&path).unwrap().len(), 1);
        text.push('\n');
        std::fs::write(&path, &text).unwrap();
        let e = load(&path).err().unwrap_or_default();
        assert!(e.contains("larger than 1048576 bytes"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn globs() {
        assert!(glob("job *", b"job 12"));
        assert!(glob("trigger", b"trigger"));
        assert!(!glob("trigger", b"trigger2"));
        assert!(glob("t?g*r", b"tagger"));
        assert!(glob("*", b""));
        assert!(!glob("?", b""));
        assert!(!glob("a*b", b"acc"));
        // `?` is one character, whatever its length in bytes; a bad byte is one too.
        assert!(glob("caf?", "café".as_bytes()));
        assert!(!glob("caf??", "café".as_bytes()));
        assert!(glob("caf?", b"caf\xE9"));
        assert!(glob("err*", b"err \xFF\xFE"));
        assert!(glob("*é", "éé".as_bytes()));
        assert!(!glob("é", b"\xC3"));
    }

    /// The definition written out: a table over (pattern units, message units), where a
    /// unit is a character or a lone invalid byte. Quadratic, obviously right.
    fn oracle(pattern: &str, message: &[u8]) -> bool {
        let p: Vec<&str> = pattern.split_inclusive(|_: char| true).collect();
        let s: Vec<&[u8]> = message
            .utf8_chunks()
            .flat_map(|c| {
                let valid = c.valid().split_inclusive(|_: char| true).map(str::as_bytes);
                valid.chain(c.invalid().chunks(1))
            })
            .collect();
        // m[i][j]: p[i..] matches s[j..].
        let mut m = vec![vec![false; s.len() + 1]; p.len() + 1];
        m[p.len()][s.len()] = true;
        for i in (0..p.len()).rev() {
            for j in (0..=s.len()).rev() {
                m[i][j] = match p[i] {
                    "*" => m[i + 1][j] || (j < s.len() && m[i][j + 1]),
                    "?" => j < s.len() && m[i + 1][j + 1],
                    lit => j < s.len() && lit.as_bytes() == s[j] && m[i + 1][j + 1],
                };
            }
        }
        m[0][0]
    }

    /// Whole characters ('a', 'b', é, €) and pieces of them or bytes that are never
    /// UTF-8, so that messages hold both valid and broken sequences.
    const PIECES: &[&[u8]] = &[
        b"a",
        b"b",
        "é".as_bytes(),
        "€".as_bytes(),
        b"\xC3",
        b"\xA9",
        b"\xE2\x82",
        b"\xE9",
        b"\xFF",
    ];

    /// A pattern and a message made to fit it, piece by piece: a literal for itself, one
    /// piece for `?`, none to three for `*`. Most pairs match, some do not (a piece of two
    /// bad bytes is two characters, and neighbouring pieces can join into one character):
    /// both outcomes are common, unlike with independent random pairs.
    fn instance() -> impl Strategy<Value = (String, Vec<u8>)> {
        let piece = prop::sample::select(PIECES);
        let token = prop_oneof![
            prop::sample::select(vec!['a', 'b', 'é', '€'])
                .prop_map(|c| (c.to_string(), c.to_string().into_bytes())),
            piece.clone().prop_map(|p| ("?".to_string(), p.to_vec())),
            proptest::collection::vec(piece, 0..3).prop_map(|ps| ("*".to_string(), ps.concat())),
        ];
        proptest::collection::vec(token, 0..8).prop_map(|tokens| {
            let mut pair = (String::new(), Vec::new());
            for (p, s) in tokens {
                pair.0.push_str(&p);
                pair.1.extend(s);
            }
            pair
        })
    }

    fn pattern() -> impl Strategy<Value = String> {
        proptest::collection::vec(
            prop::sample::select(vec!['a', 'b', 'é', '€', '*', '?']),
            0..10,
        )
        .prop_map(|v| v.into_iter().collect())
    }

    proptest! {
        #[test]
        fn glob_agrees_with_wildmatch_on_text(
            p in pattern(),
            s in proptest::collection::vec(prop::sample::select(vec!['a', 'b', 'é', '€']), 0..12),
        ) {
            let s: String = s.into_iter().collect();
            prop_assert_eq!(glob(&p, s.as_bytes()), wildmatch::WildMatch::new(&p).matches(&s));
        }

        #[test]
        fn glob_agrees_with_the_definition_on_any_bytes(
            p in pattern(),
            s in proptest::collection::vec(prop::sample::select(PIECES), 0..10)
                .prop_map(|pieces| pieces.concat()),
        ) {
            prop_assert_eq!(glob(&p, &s), oracle(&p, &s));
        }

        #[test]
        fn glob_agrees_with_the_definition_on_messages_made_to_fit((p, s) in instance()) {
            prop_assert_eq!(glob(&p, &s), oracle(&p, &s));
        }
    }
}
