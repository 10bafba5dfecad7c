//! Playing a loaded `.urp` program: read the file, translate it to URScript, and fetch
//! the External Control URCap node's script from `--urcap-host` as the URCap does.

use super::Shared;

/// The External Control URCap's default port.
pub const URCAP_PORT: u16 = 50002;

/// `HOST` or `HOST:PORT`.
pub fn parse_host(text: &str) -> Result<(String, u16), String> {
    match text.rsplit_once(':') {
        Some((host, port)) if !host.is_empty() && !host.contains(':') => {
            let port = port
                .parse::<u16>()
                .map_err(|_| format!("{port:?} is not a port number"))?;
            Ok((host.to_string(), port))
        }
        _ if !text.is_empty() => Ok((text.to_string(), URCAP_PORT)),
        _ => Err("give a host name or address".into()),
    }
}

/// The URScript of the program file at `path`.
pub fn load(shared: &Shared, path: &str) -> Result<String, String> {
    let _ = (&shared.urcap_host, path);
    Err("playing .urp files is not available yet".into())
}
