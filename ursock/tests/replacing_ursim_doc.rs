//! docs/replacing-ursim.md stays true: every option of `ursock controller` and
//! `ursock wait` it names exists (read from their `--help`), and so does every profile.

use std::process::Command;

fn help(sub: &str) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_ursock"))
        .args([sub, "--help"])
        .output()
        .unwrap();
    assert!(out.status.success());
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The `--long` options a text names: `--` after a blank or punctuation, then letters,
/// digits and dashes.
fn options(text: &str) -> Vec<String> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i + 2 < b.len() {
        let starts = b[i] == b'-'
            && b[i + 1] == b'-'
            && b[i + 2].is_ascii_alphabetic()
            && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'-'));
        if starts {
            let end = (i + 2..b.len())
                .find(|&j| !(b[j].is_ascii_alphanumeric() || b[j] == b'-'))
                .unwrap_or(b.len());
            out.push(text[i..end].to_string());
            i = end;
        } else {
            i += 1;
        }
    }
    out
}

#[test]
fn every_option_the_document_names_exists() {
    let doc = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../docs/replacing-ursim.md"
    ))
    .unwrap();
    let mut known = options(&help("controller"));
    known.extend(options(&help("wait")));
    assert!(known.iter().any(|o| o == "--ursim"), "{known:?}");
    let mut named = 0;
    // The table's rows, the lines that run ursock, and the image's command lines.
    for line in doc.lines().filter(|l| {
        l.starts_with('|') || l.contains("ursock ") || l.contains("command:") || l.contains("args:")
    }) {
        for opt in options(line) {
            named += 1;
            assert!(
                known.contains(&opt),
                "{opt} in {line:?} is no option of ursock"
            );
        }
    }
    assert!(named >= 15, "only {named} options named");
    // The profile: `--ursim`, and the library's name for it.
    let net = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../controller/src/net/mod.rs"
    ))
    .unwrap();
    assert!(net.contains("    Ursim,"), "Profile::Ursim");
    for file in ["default.installation", "external_control.urp", "wait.urp"] {
        if doc.contains(file) {
            assert!(
                std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/ursim/programs"))
                    .join(file)
                    .is_file(),
                "{file}"
            );
        }
    }
}
