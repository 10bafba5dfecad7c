//! Prints the URScript a `.urp` program translates to, as `ursock controller` runs it
//! (External Control nodes as the comment lines the translation keeps for them), or why
//! it is refused.
//!
//! ```text
//! cargo run -p urscript-controller --example urp_to_script -- program.urp
//! ```
use std::process::ExitCode;

fn main() -> ExitCode {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: urp_to_script FILE.urp");
        return ExitCode::from(2);
    };
    let bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("{path}: {e}");
            return ExitCode::from(2);
        }
    };
    match urscript_controller::read_urp(&bytes) {
        Ok(program) => {
            print!("{}", program.script);
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("{path}: {e}");
            ExitCode::FAILURE
        }
    }
}
