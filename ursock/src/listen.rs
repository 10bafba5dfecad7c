//! `ursock listen`: the socket debug assistant a robot connects to.

use std::collections::HashMap;
use std::io::{BufRead, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::{Arc, Mutex};

use urscript_socket::var::{encode_var_reply, parse_var_message, VarMessage};
use urscript_socket::RecvBuffer;

use crate::formats::{encode_server, AnyDecoder, DecodeFormat};
use crate::show::{hex, quoted, Message};

pub struct ListenOptions {
    pub bind: String,
    pub port: u16,
    pub decode: Option<DecodeFormat>,
    pub delimiter: Vec<u8>,
    pub reply: Option<Vec<String>>,
    pub exit_after: Option<usize>,
}

type Peers = Arc<Mutex<Vec<(usize, TcpStream)>>>;

pub fn listen(opts: ListenOptions) -> Result<(), String> {
    // Check the reply spec once, up front, so a typo fails at start and not per message.
    if let Some(spec) = &opts.reply {
        let (format, values) = spec.split_first().ok_or("--reply needs a format")?;
        encode_server(format, values).map_err(|e| format!("--reply: {e}"))?;
    }
    if let Some(format) = opts.decode {
        AnyDecoder::new(format, &opts.delimiter)?;
    }
    let listener = TcpListener::bind((opts.bind.as_str(), opts.port))
        .map_err(|e| format!("cannot listen on {}:{}: {e}", opts.bind, opts.port))?;
    let addr = listener.local_addr().map_err(|e| e.to_string())?;
    println!("listening on {addr}");
    let _ = std::io::stdout().flush();

    let peers: Peers = Arc::new(Mutex::new(Vec::new()));
    spawn_stdin_replies(Arc::clone(&peers));
    let opts = Arc::new(opts);
    let mut handles = Vec::new();
    let mut id = 0usize;
    for stream in listener.incoming() {
        let stream = match stream {
            Ok(s) => s,
            Err(e) => {
                eprintln!("ursock: accept failed: {e}");
                continue;
            }
        };
        id += 1;
        let (conn_opts, conn_peers) = (Arc::clone(&opts), Arc::clone(&peers));
        handles.push(std::thread::spawn(move || {
            serve(id, stream, &conn_opts, &conn_peers)
        }));
        if opts.exit_after == Some(id) {
            break;
        }
    }
    for h in handles {
        let _ = h.join();
    }
    Ok(())
}

/// Lines typed on stdin are reply specs (`floats 0.1 0.2`, `line OK`...) sent to every
/// connected robot.
fn spawn_stdin_replies(peers: Peers) {
    std::thread::spawn(move || {
        for line in std::io::stdin().lock().lines() {
            let Ok(line) = line else { return };
            let words: Vec<String> = line.split_whitespace().map(String::from).collect();
            let Some((format, values)) = words.split_first() else {
                continue;
            };
            match encode_server(format, values) {
                Ok(bytes) => {
                    let mut peers = peers.lock().unwrap_or_else(|p| p.into_inner());
                    for (id, stream) in peers.iter_mut() {
                        if stream.write_all(&bytes).is_ok() {
                            println!(
                                "[#{id}] -> {:<4} {}  {}",
                                bytes.len(),
                                hex(&bytes),
                                quoted(&bytes)
                            );
                        }
                    }
                }
                Err(e) => eprintln!("ursock: {e}"),
            }
        }
    });
}

fn serve(id: usize, mut stream: TcpStream, opts: &ListenOptions, peers: &Peers) {
    let who = stream
        .peer_addr()
        .map(|a| a.to_string())
        .unwrap_or_else(|_| "?".into());
    println!("[#{id}] connected from {who}");
    if let Ok(clone) = stream.try_clone() {
        peers
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push((id, clone));
    }
    let mut decoder = opts
        .decode
        .and_then(|f| AnyDecoder::new(f, &opts.delimiter).ok());
    let mut rx = RecvBuffer::with_capacity(64 * 1024);
    let mut vars: HashMap<String, i32> = HashMap::new();
    let mut chunk = vec![0u8; 16 * 1024];
    loop {
        let n = match stream.read(&mut chunk) {
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => {
                println!("[#{id}] read error: {e}");
                0
            }
        };
        if n > 0 {
            println!(
                "[#{id}] <- {:<4} {}  {}",
                n,
                hex(&chunk[..n]),
                quoted(&chunk[..n])
            );
        }
        let Some(dec) = decoder.as_mut() else {
            if n == 0 {
                break;
            }
            continue;
        };
        let mut taken = 0;
        loop {
            taken += rx.extend(&chunk[taken..n]);
            let mut replies: Vec<Vec<u8>> = Vec::new();
            dec.drain(&mut rx, n == 0, &mut |m| match m {
                Ok(msg) => {
                    println!("[#{id}]    = {}", msg.text());
                    if let Some(r) = reply_for(&msg, opts, &mut vars) {
                        replies.push(r);
                    }
                }
                Err(e) => println!("[#{id}]    ! {e}"),
            });
            for r in replies {
                if stream.write_all(&r).is_ok() {
                    println!("[#{id}] -> {:<4} {}  {}", r.len(), hex(&r), quoted(&r));
                }
            }
            if taken >= n {
                break;
            }
        }
        if n == 0 {
            break;
        }
    }
    println!("[#{id}] closed");
    peers
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .retain(|(i, _)| *i != id);
}

/// The automatic reply to one decoded message: `SET` is remembered and `GET` answered
/// from it; anything else gets the `--reply` spec, if one was given.
fn reply_for(
    msg: &Message<'_>,
    opts: &ListenOptions,
    vars: &mut HashMap<String, i32>,
) -> Option<Vec<u8>> {
    // Robots mix `socket_send_line` and `socket_set_var`/`socket_get_var` on one socket:
    // a line that is a variable message is handled as one.
    if let Message::Text("line", line) = msg {
        if let Ok(var) = parse_var_message(line) {
            return reply_for(&Message::Var(var), opts, vars);
        }
    }
    match msg {
        Message::Var(VarMessage::Set { name, value }) => {
            vars.insert((*name).to_string(), *value);
            None
        }
        Message::Var(VarMessage::Get { name }) => {
            let mut out = Vec::new();
            let value = vars.get(*name).copied().unwrap_or(0);
            encode_var_reply(name, value, &mut out).ok()?;
            Some(out)
        }
        _ => {
            let spec = opts.reply.as_ref()?;
            let (format, values) = spec.split_first()?;
            encode_server(format, values).ok()
        }
    }
}
