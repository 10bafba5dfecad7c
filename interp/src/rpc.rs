//! XML-RPC over HTTP/1.1 for `rpc_factory("xmlrpc", url)` handles: the URL, the request
//! bytes of a call, and the reply read back into a URScript value. Pure functions; the
//! machine ([`crate::machine`]) moves the bytes through its socket events.
//!
//! ## Types
//! | URScript | XML-RPC, sent | XML-RPC, received |
//! |---|---|---|
//! | int | `<int>` | `<int>`, `<i4>` (32-bit; out of range is an error) |
//! | float | `<double>` (nan and infinities refused) | `<double>` |
//! | bool | `<boolean>` 1/0 | `<boolean>` 1/0 |
//! | string | `<string>` (`& < >` escaped) | `<string>`, or text straight in `<value>` |
//! | list | `<array>` | `<array>` |
//! | pose | `<struct>` with members x, y, z, rx, ry, rz (as UR's XML-RPC article describes) | a `<struct>` of exactly those six numbers becomes a pose |
//! | struct | `<struct>` | any other `<struct>` becomes a struct |
//!
//! Anything else (`<nil/>`, `<base64>`, `<dateTime.iso8601>`, `<i8>`) is an error naming
//! the type, as is a thread handle, `None` or an RPC handle in the arguments: UR's
//! XML-RPC article lists only the types above, and a URScript value has no form for
//! them (no null, no date; an `<i8>` may not fit an int).
//!
//! ## HTTP
//! A reply's body ends at its `Content-Length`, at the end of its chunks
//! (`Transfer-Encoding: chunked`, as servers that stream their replies send them;
//! extensions and trailers are dropped), or, with neither, when the server closes.
//!
//! ## Bounds
//! A reply is at most [`MAX_REPLY`] bytes (headers and body), its headers at most
//! [`MAX_HEADER`] bytes, its value nested at most [`MAX_VALUE_DEPTH`] levels, a struct
//! at most [`MAX_STRUCT_MEMBERS`] members; past any of them the call is an error. The
//! parser is a single pass over the bytes, its recursion bounded by the depth bound.

use crate::value::{Value, MAX_STRUCT_MEMBERS, MAX_VALUE_DEPTH};

/// The most bytes of a reply (status line, headers and body).
pub(crate) const MAX_REPLY: usize = 1024 * 1024;

/// How long a call waits for its connection and its complete reply (program time). The
/// manual says only that the program waits for the remote function to complete; a
/// server that never answers would hold the program forever, so a call without a
/// complete reply within this time is a runtime error.
pub(crate) const TIMEOUT: std::time::Duration = std::time::Duration::from_secs(10);

/// The most bytes of a reply's status line and headers.
pub(crate) const MAX_HEADER: usize = 16 * 1024;

/// Where an `rpc_factory` URL points.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Url {
    pub host: String,
    pub port: u16,
    pub path: String,
}

/// Reads `http://host[:port][/path]` (port 80 and path `/` by default).
pub(crate) fn parse_url(url: &str) -> Result<Url, String> {
    let rest = match url.split_once("://") {
        Some((scheme, rest)) if scheme.eq_ignore_ascii_case("http") => rest,
        Some((scheme, _)) => {
            return Err(format!(
                "URL \"{url}\": scheme `{scheme}` is not supported (only http://)"
            ))
        }
        None => return Err(format!("URL \"{url}\": expected http://host[:port]/path")),
    };
    let (authority, path) = match rest.find('/') {
        Some(i) => (&rest[..i], &rest[i..]),
        None => (rest, "/"),
    };
    let (host, port) = match authority.rsplit_once(':') {
        Some((h, p)) => {
            let port = p
                .parse::<u16>()
                .map_err(|_| format!("URL \"{url}\": port `{p}` is not 0..65535"))?;
            (h, port)
        }
        None => (authority, 80),
    };
    if host.is_empty() || host.bytes().any(|b| b <= b' ' || b == b'@' || b >= 0x7f) {
        return Err(format!("URL \"{url}\": no valid host"));
    }
    if path.bytes().any(|b| b <= b' ' || b >= 0x7f) {
        return Err(format!(
            "URL \"{url}\": the path holds a space or a control character"
        ));
    }
    Ok(Url {
        host: host.to_string(),
        port,
        path: path.to_string(),
    })
}

/// The HTTP request of the call `method(args...)` to `url`.
pub(crate) fn request(url: &Url, method: &str, args: &[Value]) -> Result<Vec<u8>, String> {
    let mut body = Vec::new();
    body.extend_from_slice(b"<?xml version=\"1.0\"?>\n<methodCall><methodName>");
    escape(method.as_bytes(), &mut body);
    body.extend_from_slice(b"</methodName><params>");
    for (i, a) in args.iter().enumerate() {
        body.extend_from_slice(b"<param>");
        encode(a, &mut body).map_err(|e| format!("argument {}: {e}", i + 1))?;
        body.extend_from_slice(b"</param>");
    }
    body.extend_from_slice(b"</params></methodCall>\n");
    let mut out = format!(
        "POST {} HTTP/1.1\r\nHost: {}:{}\r\nUser-Agent: urscript-interp\r\nContent-Type: text/xml\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
        url.path,
        url.host,
        url.port,
        body.len()
    )
    .into_bytes();
    out.extend_from_slice(&body);
    Ok(out)
}

fn escape(s: &[u8], out: &mut Vec<u8>) {
    for &b in s {
        match b {
            b'&' => out.extend_from_slice(b"&amp;"),
            b'<' => out.extend_from_slice(b"&lt;"),
            b'>' => out.extend_from_slice(b"&gt;"),
            _ => out.push(b),
        }
    }
}

fn double(x: f64, out: &mut Vec<u8>) -> Result<(), String> {
    if !x.is_finite() {
        return Err(format!("XML-RPC has no double for {x}"));
    }
    // Rust writes a float without an exponent, as XML-RPC's double wants.
    out.extend_from_slice(format!("<value><double>{x:?}</double></value>").as_bytes());
    Ok(())
}

/// One `<value>`. The value's depth is bounded (the machine checked it), so the
/// recursion is.
fn encode(v: &Value, out: &mut Vec<u8>) -> Result<(), String> {
    match v {
        Value::Int(i) => out.extend_from_slice(format!("<value><int>{i}</int></value>").as_bytes()),
        Value::Float(x) => double(*x, out)?,
        Value::Bool(b) => out.extend_from_slice(
            format!("<value><boolean>{}</boolean></value>", u8::from(*b)).as_bytes(),
        ),
        Value::Str(s) => {
            out.extend_from_slice(b"<value><string>");
            escape(s, out);
            out.extend_from_slice(b"</string></value>");
        }
        Value::List(items) => {
            out.extend_from_slice(b"<value><array><data>");
            for i in items {
                encode(i, out)?;
            }
            out.extend_from_slice(b"</data></array></value>");
        }
        Value::Pose(p) => {
            out.extend_from_slice(b"<value><struct>");
            for (name, x) in POSE_MEMBERS.iter().zip(p) {
                out.extend_from_slice(format!("<member><name>{name}</name>").as_bytes());
                double(*x, out)?;
                out.extend_from_slice(b"</member>");
            }
            out.extend_from_slice(b"</struct></value>");
        }
        Value::Struct(members) => {
            out.extend_from_slice(b"<value><struct>");
            for (name, x) in members {
                out.extend_from_slice(b"<member><name>");
                escape(name.as_bytes(), out);
                out.extend_from_slice(b"</name>");
                encode(x, out)?;
                out.extend_from_slice(b"</member>");
            }
            out.extend_from_slice(b"</struct></value>");
        }
        Value::Thread(_) | Value::Rpc(_) | Value::Eip(_) | Value::None => {
            return Err(format!("a {} cannot be sent over XML-RPC", v.type_name()))
        }
    }
    Ok(())
}

/// The members of a pose as UR sends it.
const POSE_MEMBERS: [&str; 6] = ["x", "y", "z", "rx", "ry", "rz"];

/// What the bytes received so far make of a reply.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Reply {
    /// More bytes are needed (the body is shorter than its Content-Length, or the
    /// headers are not complete).
    Incomplete,
    /// The reply's value.
    Value(Value),
    /// The reply is an error: this message.
    Error(String),
}

/// Reads a reply from `bytes`; `closed`: the server has closed the connection, so no
/// more bytes will come.
pub(crate) fn reply(bytes: &[u8], closed: bool) -> Reply {
    let Some(end) = find(bytes, b"\r\n\r\n") else {
        if bytes.len() > MAX_HEADER {
            return Reply::Error(format!(
                "the reply's HTTP headers are longer than {MAX_HEADER} bytes"
            ));
        }
        return if closed {
            Reply::Error(format!(
                "the server closed the connection before the end of the HTTP headers ({} bytes received)",
                bytes.len()
            ))
        } else {
            Reply::Incomplete
        };
    };
    if end > MAX_HEADER {
        return Reply::Error(format!(
            "the reply's HTTP headers are longer than {MAX_HEADER} bytes"
        ));
    }
    let head = String::from_utf8_lossy(&bytes[..end]);
    let body = &bytes[end + 4..];
    let mut lines = head.split("\r\n");
    let status = lines.next().unwrap_or_default();
    let mut parts = status.splitn(3, ' ');
    let (version, code) = (parts.next().unwrap_or(""), parts.next().unwrap_or(""));
    if !version.starts_with("HTTP/1.") {
        return Reply::Error(format!("not an HTTP reply: \"{}\"", clip(status)));
    }
    if code != "200" {
        return Reply::Error(format!("HTTP status \"{}\"", clip(status)));
    }
    let mut length: Option<usize> = None;
    let mut chunked = false;
    for line in lines {
        let Some((name, value)) = line.split_once(':') else {
            continue;
        };
        let value = value.trim();
        if name.eq_ignore_ascii_case("content-length") {
            match value.parse::<usize>() {
                Ok(n) => length = Some(n),
                Err(_) => return Reply::Error(format!("bad Content-Length \"{}\"", clip(value))),
            }
        } else if name.eq_ignore_ascii_case("transfer-encoding") {
            if value.eq_ignore_ascii_case("chunked") {
                chunked = true;
            } else if !value.eq_ignore_ascii_case("identity") {
                return Reply::Error(format!(
                    "Transfer-Encoding \"{}\" is not supported (chunked or a Content-Length)",
                    clip(value)
                ));
            }
        }
    }
    // HTTP/1.1: a chunked body's own framing wins over any Content-Length.
    let dechunked;
    let body = if chunked {
        match dechunk(body) {
            Chunks::Body(b) => {
                dechunked = b;
                &dechunked[..]
            }
            Chunks::Incomplete if closed => {
                return Reply::Error(format!(
                    "the server closed the connection inside the reply's chunked body ({} bytes received)",
                    body.len()
                ))
            }
            Chunks::Incomplete => return Reply::Incomplete,
            Chunks::Error(e) => return Reply::Error(e),
        }
    } else {
        match length {
            Some(n) if n > MAX_REPLY => {
                return Reply::Error(format!("the reply's body of {n} bytes is over {MAX_REPLY}"))
            }
            Some(n) if body.len() >= n => &body[..n],
            Some(n) if closed => {
                return Reply::Error(format!(
                    "the server closed the connection after {} of the reply's {n} bytes",
                    body.len()
                ))
            }
            Some(_) => return Reply::Incomplete,
            None if closed => body,
            None => return Reply::Incomplete,
        }
    };
    match method_response(body) {
        Ok(Ok(v)) => Reply::Value(v),
        Ok(Err(fault)) => Reply::Error(fault),
        Err(e) => Reply::Error(format!("malformed XML-RPC reply: {e}")),
    }
}

/// What a chunked body (RFC 9112, section 7.1) received so far makes.
#[derive(Debug, PartialEq)]
enum Chunks {
    /// The whole body, the chunks' data joined (extensions and trailers dropped).
    Body(Vec<u8>),
    /// The last chunk or the blank line after the trailers has not come yet.
    Incomplete,
    Error(String),
}

/// Joins the chunks of a chunked body. Bounded: the data is at most [`MAX_REPLY`]
/// bytes (the bytes received are already under that bound, so it only guards a size
/// line's claim), a size line or trailer section at most [`MAX_HEADER`] bytes.
fn dechunk(body: &[u8]) -> Chunks {
    // The data's places first, copied only once the body is complete (a reply arriving
    // in many small reads is read again on each; this keeps each reading linear in the
    // number of chunks, not in the bytes).
    let mut data: Vec<core::ops::Range<usize>> = Vec::new();
    let mut total = 0usize;
    let mut rest = body;
    loop {
        let Some(eol) = find(rest, b"\r\n") else {
            return if rest.len() > MAX_HEADER {
                Chunks::Error(format!("a chunk size line longer than {MAX_HEADER} bytes"))
            } else {
                Chunks::Incomplete
            };
        };
        let line = String::from_utf8_lossy(&rest[..eol]);
        let size_text = line.split(';').next().unwrap_or_default().trim();
        let size = match usize::from_str_radix(size_text, 16) {
            Ok(n) if !size_text.starts_with('+') => n,
            _ => return Chunks::Error(format!("bad chunk size line \"{}\"", clip(&line))),
        };
        rest = &rest[eol + 2..];
        if size == 0 {
            // Trailers (ignored) end with a blank line.
            return if rest.starts_with(b"\r\n") || find(rest, b"\r\n\r\n").is_some() {
                let mut out = Vec::with_capacity(total);
                for r in data {
                    out.extend_from_slice(&body[r]);
                }
                Chunks::Body(out)
            } else if rest.len() > MAX_HEADER {
                Chunks::Error(format!("chunked trailers longer than {MAX_HEADER} bytes"))
            } else {
                Chunks::Incomplete
            };
        }
        if size > MAX_REPLY - total {
            return Chunks::Error(format!(
                "the reply's chunked body is over {MAX_REPLY} bytes"
            ));
        }
        if rest.len() < size + 2 {
            return Chunks::Incomplete;
        }
        if &rest[size..size + 2] != b"\r\n" {
            return Chunks::Error(format!("a chunk of {size} bytes is not followed by CRLF"));
        }
        let start = body.len() - rest.len();
        data.push(start..start + size);
        total += size;
        rest = &rest[size + 2..];
    }
}

/// At most 200 characters of a text from the reply, for a message.
fn clip(s: &str) -> String {
    s.chars().take(200).collect()
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

/// A token of the XML.
#[derive(Debug, PartialEq)]
enum Tok<'a> {
    Open(&'a str),
    Close(&'a str),
    /// `<name/>`.
    Empty(&'a str),
    Text(&'a [u8]),
    End,
}

struct Xml<'a> {
    s: &'a [u8],
    pos: usize,
}

impl<'a> Xml<'a> {
    /// The next token, skipping text that is only white space (layout between tags).
    fn next(&mut self) -> Result<Tok<'a>, String> {
        loop {
            match self.next_raw()? {
                Tok::Text(t) if t.iter().all(u8::is_ascii_whitespace) => continue,
                t => return Ok(t),
            }
        }
    }

    /// The next token, text as it is; the XML declaration and comments are skipped.
    fn next_raw(&mut self) -> Result<Tok<'a>, String> {
        loop {
            let rest = &self.s[self.pos.min(self.s.len())..];
            if rest.is_empty() {
                return Ok(Tok::End);
            }
            if rest[0] != b'<' {
                let n = rest.iter().position(|&b| b == b'<').unwrap_or(rest.len());
                self.pos += n;
                return Ok(Tok::Text(&rest[..n]));
            }
            if rest.starts_with(b"<?") {
                let n = find(rest, b"?>").ok_or("an unterminated `<?`")?;
                self.pos += n + 2;
                continue;
            }
            if rest.starts_with(b"<!--") {
                let n = find(rest, b"-->").ok_or("an unterminated comment")?;
                self.pos += n + 3;
                continue;
            }
            let n = rest
                .iter()
                .position(|&b| b == b'>')
                .ok_or("an unterminated tag")?;
            self.pos += n + 1;
            let inner = std::str::from_utf8(&rest[1..n]).map_err(|_| "a tag that is not UTF-8")?;
            if let Some(name) = inner.strip_prefix('/') {
                return Ok(Tok::Close(name.trim()));
            }
            if let Some(name) = inner.strip_suffix('/') {
                return Ok(Tok::Empty(tag_name(name)));
            }
            return Ok(Tok::Open(tag_name(inner)));
        }
    }

    /// Whether a tag other than a closing one follows (white space before it is then
    /// layout, not a string's text).
    fn peek_is_open(&self) -> bool {
        let rest = &self.s[self.pos.min(self.s.len())..];
        rest.starts_with(b"<") && !rest.starts_with(b"</")
    }

    fn expect_open(&mut self, name: &str) -> Result<(), String> {
        match self.next()? {
            Tok::Open(n) if n == name => Ok(()),
            t => Err(format!("expected <{name}>, found {}", describe(&t))),
        }
    }

    fn expect_close(&mut self, name: &str) -> Result<(), String> {
        match self.next()? {
            Tok::Close(n) if n == name => Ok(()),
            t => Err(format!("expected </{name}>, found {}", describe(&t))),
        }
    }

    /// The text of a scalar element, then its closing tag.
    fn text_of(&mut self, name: &str) -> Result<String, String> {
        match self.next_raw()? {
            Tok::Close(n) if n == name => Ok(String::new()),
            Tok::Text(t) => {
                let s = unescape(t)?;
                self.expect_close(name)?;
                Ok(s)
            }
            t => Err(format!(
                "expected the text of <{name}>, found {}",
                describe(&t)
            )),
        }
    }
}

/// The name of a tag without its attributes.
fn tag_name(inner: &str) -> &str {
    inner.split_ascii_whitespace().next().unwrap_or("")
}

fn describe(t: &Tok<'_>) -> String {
    match t {
        Tok::Open(n) => format!("<{}>", clip(n)),
        Tok::Close(n) => format!("</{}>", clip(n)),
        Tok::Empty(n) => format!("<{}/>", clip(n)),
        Tok::Text(t) => format!("text \"{}\"", clip(&String::from_utf8_lossy(t))),
        Tok::End => "the end of the reply".into(),
    }
}

/// XML's five entities and character references.
fn unescape(t: &[u8]) -> Result<String, String> {
    let s = std::str::from_utf8(t).map_err(|_| "text that is not UTF-8".to_string())?;
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(i) = rest.find('&') {
        out.push_str(&rest[..i]);
        let after = &rest[i + 1..];
        let end = after
            .find(';')
            .filter(|&e| e <= 10)
            .ok_or_else(|| format!("a bad entity near \"{}\"", clip(after)))?;
        let ent = &after[..end];
        let c = match ent {
            "lt" => '<',
            "gt" => '>',
            "amp" => '&',
            "quot" => '"',
            "apos" => '\'',
            _ => {
                let code = if let Some(h) = ent.strip_prefix("#x") {
                    u32::from_str_radix(h, 16).ok()
                } else if let Some(d) = ent.strip_prefix('#') {
                    d.parse::<u32>().ok()
                } else {
                    None
                };
                code.and_then(char::from_u32)
                    .ok_or_else(|| format!("an unknown entity `&{ent};`"))?
            }
        };
        out.push(c);
        rest = &after[end + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

/// `<methodResponse>`: `Ok(Ok(value))`, or `Ok(Err(message))` for a fault.
fn method_response(body: &[u8]) -> Result<Result<Value, String>, String> {
    let mut x = Xml { s: body, pos: 0 };
    x.expect_open("methodResponse")?;
    let out = match x.next()? {
        Tok::Open("params") => {
            let v = match x.next()? {
                Tok::Open("param") => {
                    x.expect_open("value")?;
                    let v = value(&mut x, 0)?;
                    x.expect_close("param")?;
                    x.expect_close("params")?;
                    v
                }
                // No value: the method returned nothing.
                Tok::Close("params") => Value::None,
                t => return Err(format!("expected <param>, found {}", describe(&t))),
            };
            Ok(v)
        }
        Tok::Empty("params") => Ok(Value::None),
        Tok::Open("fault") => {
            x.expect_open("value")?;
            let v = value(&mut x, 0)?;
            x.expect_close("fault")?;
            let member = |name: &str| match &v {
                Value::Struct(m) => m.iter().find(|(n, _)| n == name).map(|(_, v)| v.clone()),
                _ => None,
            };
            let code = member("faultCode").map_or_else(|| "?".into(), |c| c.to_str());
            let text = member("faultString").map_or_else(String::new, |s| s.to_str());
            Err(format!(
                "the server answered with fault {code}: {}",
                clip(&text)
            ))
        }
        t => {
            return Err(format!(
                "expected <params> or <fault>, found {}",
                describe(&t)
            ))
        }
    };
    x.expect_close("methodResponse")?;
    match x.next()? {
        Tok::End => Ok(out),
        t => Err(format!("{} after </methodResponse>", describe(&t))),
    }
}

/// The value after its `<value>` (consumed), through `</value>`, at `depth` levels of
/// arrays and structs.
fn value(x: &mut Xml<'_>, depth: usize) -> Result<Value, String> {
    let mut first = x.next_raw()?;
    // White space before a typed value's tag is layout, not a string.
    if matches!(&first, Tok::Text(t) if t.iter().all(u8::is_ascii_whitespace)) && x.peek_is_open() {
        first = x.next_raw()?;
    }
    let v = match first {
        Tok::Close("value") => return Ok(Value::Str(Vec::new())),
        Tok::Text(t) => {
            let s = unescape(t)?;
            x.expect_close("value")?;
            return Ok(Value::Str(s.into_bytes()));
        }
        Tok::Open(ty @ ("int" | "i4")) => {
            let t = x.text_of(ty)?;
            let t = t.trim();
            Value::Int(
                t.parse::<i32>()
                    .map_err(|_| format!("<{ty}> \"{}\" is not a 32-bit int", clip(t)))?,
            )
        }
        Tok::Open("double") => {
            let t = x.text_of("double")?;
            let t = t.trim();
            Value::Float(
                t.parse::<f64>()
                    .map_err(|_| format!("<double> \"{}\" is not a number", clip(t)))?,
            )
        }
        Tok::Open("boolean") => match x.text_of("boolean")?.trim() {
            "1" => Value::Bool(true),
            "0" => Value::Bool(false),
            t => return Err(format!("<boolean> \"{}\" is not 0 or 1", clip(t))),
        },
        Tok::Open("string") => Value::Str(x.text_of("string")?.into_bytes()),
        Tok::Empty("string") => Value::Str(Vec::new()),
        Tok::Open("array") => {
            if depth >= MAX_VALUE_DEPTH {
                return Err(format!("values nested more than {MAX_VALUE_DEPTH} levels"));
            }
            let mut items = Vec::new();
            match x.next()? {
                Tok::Open("data") => loop {
                    match x.next()? {
                        Tok::Open("value") => items.push(value(x, depth + 1)?),
                        Tok::Close("data") => break,
                        t => {
                            return Err(format!(
                                "expected <value> or </data>, found {}",
                                describe(&t)
                            ))
                        }
                    }
                },
                Tok::Empty("data") => {}
                t => return Err(format!("expected <data>, found {}", describe(&t))),
            }
            x.expect_close("array")?;
            Value::List(items)
        }
        Tok::Open("struct") => {
            if depth >= MAX_VALUE_DEPTH {
                return Err(format!("values nested more than {MAX_VALUE_DEPTH} levels"));
            }
            let mut members: Vec<(String, Value)> = Vec::new();
            loop {
                match x.next()? {
                    Tok::Open("member") => {}
                    Tok::Close("struct") => break,
                    t => {
                        return Err(format!(
                            "expected <member> or </struct>, found {}",
                            describe(&t)
                        ))
                    }
                }
                x.expect_open("name")?;
                let name = x.text_of("name")?;
                x.expect_open("value")?;
                let v = value(x, depth + 1)?;
                x.expect_close("member")?;
                if members.len() >= MAX_STRUCT_MEMBERS {
                    return Err(format!(
                        "a struct of more than {MAX_STRUCT_MEMBERS} members"
                    ));
                }
                match members.iter_mut().find(|(n, _)| *n == name) {
                    Some(m) => m.1 = v,
                    None => members.push((name, v)),
                }
            }
            as_pose(&members).unwrap_or(Value::Struct(members))
        }
        Tok::Open(other) | Tok::Empty(other) => {
            return Err(format!(
                "the XML-RPC type <{}> is not supported",
                clip(other)
            ))
        }
        t => return Err(format!("expected a value, found {}", describe(&t))),
    };
    x.expect_close("value")?;
    Ok(v)
}

/// A struct of exactly the members x, y, z, rx, ry, rz, all numbers, is a pose.
fn as_pose(members: &[(String, Value)]) -> Option<Value> {
    if members.len() != 6 {
        return None;
    }
    let mut p = [0.0; 6];
    for (slot, name) in p.iter_mut().zip(POSE_MEMBERS) {
        *slot = members.iter().find(|(n, _)| n == name)?.1.as_f64()?;
    }
    Some(Value::Pose(p))
}

/// The socket name an XML-RPC call's connection goes by in [`Event`](crate::Event)s and
/// [`CallRecord`](crate::CallRecord)s: `rpc:` and the URL, never a name a program gives
/// `socket_open` in practice.
pub(crate) fn socket_name(url: &str) -> String {
    format!("rpc:{url}")
}

/// A call under way: connecting, then waiting for the reply.
#[derive(Debug, Clone)]
pub(crate) struct Pending {
    /// [`socket_name`] of the URL.
    pub socket: String,
    pub url: String,
    pub method: String,
    /// The request, until the connection is up and it is sent.
    pub request: Option<Vec<u8>>,
    /// The reply's bytes so far (at most [`MAX_REPLY`]).
    pub reply: Vec<u8>,
    /// The step at which the call times out.
    pub deadline: u64,
    /// Where the call is.
    pub line: u32,
    pub col: u32,
    /// Its record, when calls are traced.
    pub record: Option<Box<crate::event::CallRecord>>,
}

impl Pending {
    /// The message of a failed call.
    pub fn failure(&self, why: &str) -> String {
        format!("XML-RPC call `{}` to {}: {why}", self.method, self.url)
    }

    /// Bytes from the server: the reply if they complete it (or make it an error).
    pub fn receive(&mut self, bytes: &[u8]) -> Reply {
        let room = MAX_REPLY.saturating_sub(self.reply.len());
        if bytes.len() > room {
            return Reply::Error(format!("the reply is longer than {MAX_REPLY} bytes"));
        }
        self.reply.extend_from_slice(bytes);
        reply(&self.reply, false)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn http(body: &str) -> Vec<u8> {
        format!(
            "HTTP/1.0 200 OK\r\nContent-Type: text/xml\r\nContent-Length: {}\r\n\r\n{body}",
            body.len()
        )
        .into_bytes()
    }

    fn ok(v: &str) -> Vec<u8> {
        http(&format!(
            "<?xml version='1.0'?>\n<methodResponse>\n<params>\n<param>\n<value>{v}</value>\n</param>\n</params>\n</methodResponse>\n"
        ))
    }

    #[test]
    fn urls() {
        assert_eq!(
            parse_url("http://192.168.1.10:8000/RPC2").unwrap(),
            Url {
                host: "192.168.1.10".into(),
                port: 8000,
                path: "/RPC2".into()
            }
        );
        assert_eq!(parse_url("http://cam").unwrap().port, 80);
        assert_eq!(parse_url("http://cam").unwrap().path, "/");
        assert!(parse_url("https://cam/").unwrap_err().contains("https"));
        assert!(parse_url("cam:80").is_err());
        assert!(parse_url("http://:80/").is_err());
        assert!(parse_url("http://cam:99999/")
            .unwrap_err()
            .contains("99999"));
    }

    #[test]
    fn request_bytes() {
        let url = parse_url("http://h:8/RPC2").unwrap();
        let args = [
            Value::Int(1),
            Value::Str(b"a<b&".to_vec()),
            Value::Pose([0.1, 0.0, 0.3, 0.0, 3.5, 0.0]),
            Value::List(vec![Value::Bool(true), Value::Float(-2.5)]),
        ];
        let r = String::from_utf8(request(&url, "get", &args).unwrap()).unwrap();
        let (head, body) = r.split_once("\r\n\r\n").unwrap();
        assert!(head.starts_with("POST /RPC2 HTTP/1.1\r\n"));
        assert!(head.contains("\r\nContent-Type: text/xml\r\n"));
        assert!(head.contains(&format!("\r\nContent-Length: {}", body.len())));
        assert!(body.contains("<methodName>get</methodName>"));
        assert!(body.contains("<value><int>1</int></value>"));
        assert!(body.contains("<string>a&lt;b&amp;</string>"));
        assert!(
            body.contains("<member><name>rx</name><value><double>0.0</double></value></member>")
        );
        assert!(
            body.contains("<member><name>ry</name><value><double>3.5</double></value></member>")
        );
        assert!(body.contains("<array><data><value><boolean>1</boolean></value><value><double>-2.5</double></value></data></array>"));
        assert!(request(&url, "f", &[Value::Float(f64::NAN)]).is_err());
        assert!(request(&url, "f", &[Value::None])
            .unwrap_err()
            .contains("argument 1"));
    }

    #[test]
    fn replies() {
        assert_eq!(
            reply(&ok("<int>-7</int>"), false),
            Reply::Value(Value::Int(-7))
        );
        assert_eq!(reply(&ok("<i4>7</i4>"), false), Reply::Value(Value::Int(7)));
        assert_eq!(
            reply(&ok("<double>2.5</double>"), false),
            Reply::Value(Value::Float(2.5))
        );
        assert_eq!(
            reply(&ok("<boolean>1</boolean>"), false),
            Reply::Value(Value::Bool(true))
        );
        assert_eq!(
            reply(&ok("<string>a &amp; &#x42;</string>"), false),
            Reply::Value(Value::Str(b"a & B".to_vec()))
        );
        assert_eq!(
            reply(&ok("plain"), false),
            Reply::Value(Value::Str(b"plain".to_vec()))
        );
        assert_eq!(
            reply(&ok("<string></string>"), false),
            Reply::Value(Value::Str(vec![]))
        );
        let pose = "<struct><member><name>x</name><value><double>0.1</double></value></member><member><name>y</name><value><double>0.2</double></value></member><member><name>z</name><value><double>0.3</double></value></member><member><name>rx</name><value><double>0</double></value></member><member><name>ry</name><value><int>3</int></value></member><member><name>rz</name><value><double>0</double></value></member></struct>";
        assert_eq!(
            reply(&ok(pose), false),
            Reply::Value(Value::Pose([0.1, 0.2, 0.3, 0.0, 3.0, 0.0]))
        );
        assert_eq!(
            reply(&ok("<struct><member><name>ok</name><value><boolean>0</boolean></value></member></struct>"), false),
            Reply::Value(Value::Struct(vec![("ok".into(), Value::Bool(false))]))
        );
        assert_eq!(
            reply(&ok("<array><data>\n<value><int>1</int></value>\n<value><array><data></data></array></value></data></array>"), false),
            Reply::Value(Value::List(vec![Value::Int(1), Value::List(vec![])]))
        );
        let fault = http("<methodResponse><fault><value><struct><member><name>faultCode</name><value><int>1</int></value></member><member><name>faultString</name><value><string>no such method</string></value></member></struct></value></fault></methodResponse>");
        assert_eq!(
            reply(&fault, false),
            Reply::Error("the server answered with fault 1: no such method".into())
        );
    }

    #[test]
    fn incomplete_and_closed() {
        let full = ok("<int>1</int>");
        for n in 0..full.len() {
            assert_eq!(reply(&full[..n], false), Reply::Incomplete, "{n} bytes");
            assert!(
                matches!(reply(&full[..n], true), Reply::Error(_)),
                "{n} bytes"
            );
        }
        // Without a Content-Length the reply ends when the server closes.
        let body = "<methodResponse><params><param><value><int>5</int></value></param></params></methodResponse>";
        let no_len = format!("HTTP/1.0 200 OK\r\n\r\n{body}").into_bytes();
        assert_eq!(reply(&no_len, false), Reply::Incomplete);
        assert_eq!(reply(&no_len, true), Reply::Value(Value::Int(5)));
    }

    #[test]
    fn chunked_replies() {
        let body = "<methodResponse><params><param><value><int>7</int></value></param></params></methodResponse>";
        let (a, b) = body.split_at(40);
        let whole = format!(
            "HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n{:x};ext=1\r\n{a}\r\n{:X}\r\n{b}\r\n0\r\nX-Trailer: t\r\n\r\n",
            a.len(),
            b.len()
        )
        .into_bytes();
        assert_eq!(reply(&whole, false), Reply::Value(Value::Int(7)));
        // Every cut before the end waits for more, or is an error once the server closed.
        for n in 0..whole.len() {
            assert_eq!(reply(&whole[..n], false), Reply::Incomplete, "{n} bytes");
            assert!(
                matches!(reply(&whole[..n], true), Reply::Error(_)),
                "{n} bytes"
            );
        }
        // No trailers; and a Content-Length beside chunked is ignored (RFC 9112).
        let plain = format!(
            "HTTP/1.1 200 OK\r\nContent-Length: 3\r\nTransfer-Encoding: chunked\r\n\r\n{:x}\r\n{body}\r\n0\r\n\r\n",
            body.len()
        );
        assert_eq!(reply(plain.as_bytes(), true), Reply::Value(Value::Int(7)));
    }

    #[test]
    fn hostile_replies() {
        let err = |b: &[u8]| match reply(b, true) {
            Reply::Error(e) => e,
            other => panic!("{other:?}"),
        };
        assert!(err(b"HTTP/1.1 404 Not Found\r\n\r\n").contains("404"));
        assert!(err(b"SSH-2.0\r\n\r\n").contains("not an HTTP reply"));
        assert!(err(&ok("<int>99999999999</int>")).contains("32-bit"));
        assert!(err(&ok("<double>x</double>")).contains("not a number"));
        assert!(err(&ok("<boolean>2</boolean>")).contains("0 or 1"));
        assert!(err(&ok("<base64>AA==</base64>")).contains("base64"));
        assert!(err(&ok("<nil/>")).contains("nil"));
        assert!(err(&ok("<int>1</int><int>2</int>")).contains("malformed"));
        assert!(err(&ok("<string>&bogus;</string>")).contains("entity"));
        assert!(err(&http("<methodResponse><params>")).contains("malformed"));
        // Deep nesting stops at the value depth bound, without recursion past it.
        let deep = "<array><data><value>".repeat(10_000);
        assert!(err(&ok(&deep)).contains("nested"));
        let deep = "<struct><member><name>a</name><value>".repeat(10_000);
        assert!(err(&ok(&deep)).contains("nested"));
        // Too many struct members.
        let many: String = (0..100)
            .map(|i| format!("<member><name>m{i}</name><value><int>1</int></value></member>"))
            .collect();
        assert!(err(&ok(&format!("<struct>{many}</struct>"))).contains("members"));
        // A huge declared body, or endless headers.
        let huge = format!(
            "HTTP/1.1 200 OK\r\nContent-Length: {}\r\n\r\n",
            MAX_REPLY + 1
        );
        assert!(err(huge.as_bytes()).contains("over"));
        let endless = vec![b'a'; MAX_HEADER + 1];
        assert!(matches!(reply(&endless, false), Reply::Error(e) if e.contains("headers")));
        assert!(err(b"HTTP/1.1 200 OK\r\nTransfer-Encoding: gzip\r\n\r\n").contains("gzip"));
        assert!(err(b"HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n").contains("chunked"));
        let chunked = |s: &str| format!("HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n{s}");
        assert!(err(chunked("zz\r\n").as_bytes()).contains("chunk size"));
        assert!(err(chunked("+3\r\nabc\r\n0\r\n\r\n").as_bytes()).contains("chunk size"));
        assert!(err(chunked("3\r\nabcd\r\n0\r\n\r\n").as_bytes()).contains("CRLF"));
        assert!(err(chunked("FFFFFFFFFFFF\r\n").as_bytes()).contains("over"));
        assert!(err(chunked(&"1".repeat(MAX_HEADER + 1)).as_bytes()).contains("size line"));
        assert!(err(b"HTTP/1.1 200 OK\r\nContent-Length: -1\r\n\r\n").contains("Content-Length"));
    }

    proptest::proptest! {
        #[test]
        fn never_panics(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..400), closed: bool) {
            let _ = reply(&bytes, closed);
            let mut framed = b"HTTP/1.1 200 OK\r\n\r\n".to_vec();
            framed.extend_from_slice(&bytes);
            let _ = reply(&framed, closed);
        }
    }
}
