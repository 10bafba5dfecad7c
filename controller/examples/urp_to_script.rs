//! Prints the URScript a `.urp` program translates to, as `ursock controller` runs it
//! (External Control nodes as the comment lines the translation keeps for them), or why
//! it is refused.
//!
//! With `--reply FILE`, External Control nodes get FILE's bytes as the URCap's host's
//! reply (the script as played), without a network.
//!
//! ```text
//! cargo run -p urscript-controller --example urp_to_script -- program.urp
//! cargo run -p urscript-controller --example urp_to_script -- program.urp --reply script.txt
//! ```
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (path, reply) = match &args[..] {
        [path] => (path.clone(), None),
        [path, flag, reply] if flag == "--reply" => (path.clone(), Some(reply.clone())),
        _ => {
            eprintln!("usage: urp_to_script FILE.urp [--reply FILE]");
            return ExitCode::from(2);
        }
    };
    let reply = match reply.map(|r| std::fs::read(&r).map_err(|e| format!("{r}: {e}"))) {
        None => None,
        Some(Ok(b)) => Some(String::from_utf8_lossy(&b).into_owned()),
        Some(Err(e)) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    let bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("{path}: {e}");
            return ExitCode::from(2);
        }
    };
    let script = urscript_controller::read_urp(&bytes).and_then(|program| match &reply {
        None => Ok(program.script),
        Some(reply) => urscript_controller::translate_with(&program, |_| Ok(reply.clone())),
    });
    match script {
        Ok(script) => {
            print!("{script}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("{path}: {e}");
            ExitCode::FAILURE
        }
    }
}
