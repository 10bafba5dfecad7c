//! Detects whether the compiler has `<[T]>::as_chunks` (stable since Rust 1.88), so the int32
//! decoder can iterate `[u8; 4]` values on newer compilers while the crate still builds on its
//! `rust-version`. Sets `cfg(has_as_chunks)`; any failure to read the version leaves it unset
//! (the portable path, same results).

use std::process::Command;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rustc-check-cfg=cfg(has_as_chunks)");
    let rustc = std::env::var_os("RUSTC").unwrap_or_else(|| "rustc".into());
    let Ok(out) = Command::new(rustc).arg("--version").output() else {
        return;
    };
    // "rustc 1.95.0 (59807616e 2026-04-14)": the minor version is the second field.
    let text = String::from_utf8_lossy(&out.stdout);
    let minor = text
        .split_whitespace()
        .nth(1)
        .and_then(|v| v.split('.').nth(1))
        .and_then(|m| m.parse::<u32>().ok());
    if minor.is_some_and(|m| m >= 88) {
        println!("cargo:rustc-cfg=has_as_chunks");
    }
}
