//! Every JSON line `ursock` prints matches the documented schema: `docs/json-events.schema.json`
//! (the schema written once, as data), checked here by a small hand-written validator of
//! the JSON Schema keywords it uses. `listen --json` runs with a real TCP client on
//! 127.0.0.1; `read --json` and `decode --json` run on stdin. The examples in
//! `docs/json-events.md` are checked too, and every event of the schema has one.

mod controller_common;
mod listen_common;
mod run_common;

use std::io::Write;

use serde_json::Value;

use controller_common::Controller;
use listen_common::{read_line, robot, Listener, TempFile};
use run_common::run;

fn schema() -> Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../docs/json-events.schema.json"
    );
    let text = std::fs::read_to_string(path).expect("docs/json-events.schema.json");
    serde_json::from_str(&text).expect("the schema is JSON")
}

/// `#/$defs/NAME` of the schema.
fn resolve<'a>(root: &'a Value, reference: &str) -> Result<&'a Value, String> {
    let name = reference
        .strip_prefix("#/$defs/")
        .ok_or_else(|| format!("unsupported $ref {reference}"))?;
    root["$defs"]
        .get(name)
        .ok_or_else(|| format!("no definition {name}"))
}

fn type_matches(v: &Value, ty: &str) -> bool {
    match ty {
        "null" => v.is_null(),
        "boolean" => v.is_boolean(),
        "integer" => v.is_i64() || v.is_u64(),
        "number" => v.is_number(),
        "string" => v.is_string(),
        "array" => v.is_array(),
        "object" => v.is_object(),
        _ => false,
    }
}

/// The schema's pattern for `time`: RFC 3339, milliseconds, `Z` or a `+HH:MM` offset.
const TIME_PATTERN: &str =
    "^[0-9]{4}-[0-9]{2}-[0-9]{2}T[0-9]{2}:[0-9]{2}:[0-9]{2}[.][0-9]{3}(Z|[+-][0-9]{2}:[0-9]{2})$";

/// [`TIME_PATTERN`], checked by hand: the shape, then that it names a real instant
/// (jiff parses it as RFC 3339). Returns the offset part (`Z` or `+05:30`).
fn rfc3339_millis(s: &str) -> Result<&str, String> {
    let b = s.as_bytes();
    let digits =
        |r: std::ops::Range<usize>| b.get(r).is_some_and(|d| d.iter().all(u8::is_ascii_digit));
    let shape = b.len() >= 24
        && digits(0..4)
        && b[4] == b'-'
        && digits(5..7)
        && b[7] == b'-'
        && digits(8..10)
        && b[10] == b'T'
        && digits(11..13)
        && b[13] == b':'
        && digits(14..16)
        && b[16] == b':'
        && digits(17..19)
        && b[19] == b'.'
        && digits(20..23);
    let offset = s.get(23..).unwrap_or("");
    let ob = offset.as_bytes();
    let offset_ok = offset == "Z"
        || (ob.len() == 6
            && (ob[0] == b'+' || ob[0] == b'-')
            && ob[1..3].iter().all(u8::is_ascii_digit)
            && ob[3] == b':'
            && ob[4..6].iter().all(u8::is_ascii_digit));
    if !shape || !offset_ok {
        return Err(
            "not RFC 3339 with milliseconds (YYYY-MM-DDTHH:MM:SS.mmm and Z or +HH:MM)".into(),
        );
    }
    s.parse::<jiff::Timestamp>()
        .map_err(|e| format!("not a valid instant: {e}"))?;
    Ok(offset)
}

#[test]
fn the_time_check_refuses_what_is_not_rfc3339() {
    assert_eq!(rfc3339_millis("2026-11-23T21:40:01.123Z"), Ok("Z"));
    assert_eq!(
        rfc3339_millis("2026-11-24T03:10:01.123+05:30"),
        Ok("+05:30")
    );
    for bad in [
        "2026-11-23T21:40:01Z",
        "2026-11-23T21:40:01.123",
        "2026-11-23 21:40:01.123Z",
        "2026-13-23T21:40:01.123Z",
        "2026-11-23T21:40:01.123+0530",
        "21:40:01.123",
    ] {
        assert!(rfc3339_millis(bad).is_err(), "{bad}");
    }
}

/// `listen --json` under a fixed zone (a POSIX `TZ` string, no zone files needed): the
/// stamps carry that zone's offset; with `--utc` they end in `Z`.
#[test]
fn listen_json_time_is_local_with_its_offset_or_utc() {
    for (utc, want) in [(false, "+05:30"), (true, "Z")] {
        let mut args = vec!["--json"];
        if utc {
            args.push("--utc");
        }
        let mut l = Listener::start_env(&[("TZ", "XST-5:30")], &args);
        l.type_line("list");
        let out = l.wait_for("\"list\"", false);
        let root = schema();
        for line in out.lines() {
            let v = check_event(&root, line);
            let time = v["time"].as_str().expect("listen events carry time");
            assert_eq!(rfc3339_millis(time), Ok(want), "{line}");
        }
    }
}

/// The keywords the schema uses: `$ref`, `type`, `const`, `enum`, `oneOf`, `properties`,
/// `required`, `additionalProperties: false`, `items`, `minItems`, `maxItems`, `minimum`,
/// `maximum`, `pattern` (only `^([0-9a-f]{2})+$`). Any other keyword is an error, so the
/// schema cannot say more than is checked.
fn validate(root: &Value, schema: &Value, v: &Value, at: &str) -> Result<(), String> {
    let obj = schema
        .as_object()
        .ok_or_else(|| format!("{at}: schema is not an object"))?;
    for (key, rule) in obj {
        match key.as_str() {
            "description" | "title" | "$schema" | "$defs" => {}
            "$ref" => validate(root, resolve(root, rule.as_str().unwrap_or(""))?, v, at)?,
            "type" => {
                let ok = match rule {
                    Value::String(t) => type_matches(v, t),
                    Value::Array(ts) => {
                        ts.iter().any(|t| type_matches(v, t.as_str().unwrap_or("")))
                    }
                    _ => false,
                };
                if !ok {
                    return Err(format!("{at}: {v} is not of type {rule}"));
                }
            }
            "const" => {
                if v != rule {
                    return Err(format!("{at}: {v} is not {rule}"));
                }
            }
            "enum" => {
                if !rule.as_array().is_some_and(|a| a.contains(v)) {
                    return Err(format!("{at}: {v} is not one of {rule}"));
                }
            }
            "oneOf" => {
                let options = rule.as_array().ok_or("oneOf is not an array")?;
                let mut errors = Vec::new();
                let mut matched = 0;
                for o in options {
                    match validate(root, o, v, at) {
                        Ok(()) => matched += 1,
                        Err(e) => errors.push(e),
                    }
                }
                if matched != 1 {
                    return Err(format!(
                        "{at}: {v} matches {matched} of oneOf (want 1): {errors:?}"
                    ));
                }
            }
            "properties" => {
                let Some(fields) = v.as_object() else {
                    continue;
                };
                let props = rule.as_object().ok_or("properties is not an object")?;
                for (name, value) in fields {
                    if let Some(s) = props.get(name) {
                        validate(root, s, value, &format!("{at}.{name}"))?;
                    } else if obj.get("additionalProperties") == Some(&Value::Bool(false)) {
                        return Err(format!("{at}: undocumented field {name:?} in {v}"));
                    }
                }
            }
            "additionalProperties" => {
                if rule != &Value::Bool(false) {
                    return Err(format!(
                        "{at}: only additionalProperties: false is supported"
                    ));
                }
            }
            "required" => {
                for name in rule.as_array().ok_or("required is not an array")? {
                    let name = name.as_str().unwrap_or("");
                    if v.is_object() && v.get(name).is_none() {
                        return Err(format!("{at}: required field {name:?} missing in {v}"));
                    }
                }
            }
            "items" => {
                if let Some(items) = v.as_array() {
                    for (i, item) in items.iter().enumerate() {
                        validate(root, rule, item, &format!("{at}[{i}]"))?;
                    }
                }
            }
            "minItems" | "maxItems" => {
                if let Some(items) = v.as_array() {
                    let n = rule.as_u64().unwrap_or(0) as usize;
                    let ok = if key == "minItems" {
                        items.len() >= n
                    } else {
                        items.len() <= n
                    };
                    if !ok {
                        return Err(format!("{at}: {} items breaks {key} {n}", items.len()));
                    }
                }
            }
            "minimum" | "maximum" => {
                if let (Some(x), Some(bound)) = (v.as_f64(), rule.as_f64()) {
                    let ok = if key == "minimum" {
                        x >= bound
                    } else {
                        x <= bound
                    };
                    if !ok {
                        return Err(format!("{at}: {x} breaks {key} {bound}"));
                    }
                }
            }
            "pattern" if rule == TIME_PATTERN => {
                if let Some(s) = v.as_str() {
                    rfc3339_millis(s).map_err(|e| format!("{at}: {s:?}: {e}"))?;
                }
            }
            "pattern" => {
                if rule != "^([0-9a-f]{2})+$" {
                    return Err(format!("{at}: unsupported pattern {rule}"));
                }
                if let Some(s) = v.as_str() {
                    let ok = !s.is_empty()
                        && s.len() % 2 == 0
                        && s.bytes()
                            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b));
                    if !ok {
                        return Err(format!("{at}: {s:?} is not lower-case hex bytes"));
                    }
                }
            }
            other => return Err(format!("{at}: unsupported schema keyword {other}")),
        }
    }
    Ok(())
}

/// Checks one line of an event stream: JSON, an object with an `event` the schema
/// documents, matching that event's definition and the schema as a whole.
fn check_event(root: &Value, line: &str) -> Value {
    let v: Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("{e}: {line}"));
    let name = v["event"]
        .as_str()
        .unwrap_or_else(|| panic!("no \"event\" key: {line}"));
    let def = root["$defs"]
        .get(name)
        .unwrap_or_else(|| panic!("event {name:?} is not in the schema: {line}"));
    validate(root, def, &v, name).unwrap_or_else(|e| panic!("{e}\nline: {line}"));
    validate(root, root, &v, "line").unwrap_or_else(|e| panic!("{e}\nline: {line}"));
    v
}

fn check_message(root: &Value, line: &str) -> Value {
    let v: Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("{e}: {line}"));
    let def = resolve(root, "#/$defs/typed_message").unwrap();
    validate(root, def, &v, "message").unwrap_or_else(|e| panic!("{e}\nline: {line}"));
    v
}

fn event_names(root: &Value) -> Vec<String> {
    root["oneOf"]
        .as_array()
        .expect("the schema's top-level oneOf lists the events")
        .iter()
        .map(|r| {
            r["$ref"]
                .as_str()
                .and_then(|s| s.strip_prefix("#/$defs/"))
                .expect("a $ref")
                .to_string()
        })
        .collect()
}

#[test]
fn the_validator_rejects_what_the_schema_does_not_say() {
    let root = schema();
    let bad = [
        r#"{"event":"rx","t":0.1,"len":1}"#,
        r#"{"event":"rx","t":0.1,"conn":1,"len":1,"bytes":{"encoding":"hex","hex":"E9"}}"#,
        r#"{"event":"rx","t":0.1,"conn":1,"len":1,"bytes":{"encoding":"utf-8","text":"a"},"data":"a"}"#,
        r#"{"event":"read","t":0.1,"call":"x","result":{"pose":[1,2]},"sentinel":false,"why":null}"#,
        r#"{"event":"end","t":0.1,"outcome":"crashed"}"#,
        r#"{"event":"tx","t":"now","len":1,"bytes":{"encoding":"utf-8","text":"a"}}"#,
    ];
    for line in bad {
        let v: Value = serde_json::from_str(line).unwrap();
        let def = &root["$defs"][v["event"].as_str().unwrap()];
        assert!(validate(&root, def, &v, "x").is_err(), "accepted {line}");
        assert!(validate(&root, &root, &v, "x").is_err(), "accepted {line}");
    }
    let good = r#"{"event":"rx","t":0.1,"conn":1,"len":1,"bytes":{"encoding":"hex","hex":"e9"}}"#;
    check_event(&root, good);
}

#[test]
fn every_event_is_documented_with_an_example_that_matches() {
    let root = schema();
    let doc = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../docs/json-events.md"
    ))
    .expect("docs/json-events.md");
    let mut in_json = false;
    let mut examples = Vec::new();
    let mut messages = 0;
    for line in doc.lines() {
        match line.trim() {
            "```json" => in_json = true,
            "```" => in_json = false,
            l if in_json && l.starts_with('{') => {
                if l.contains("\"event\"") {
                    examples.push(check_event(&root, l)["event"].as_str().unwrap().to_string());
                } else {
                    check_message(&root, l);
                    messages += 1;
                }
            }
            _ => {}
        }
    }
    for name in event_names(&root) {
        assert!(
            examples.contains(&name),
            "no example of {name} in docs/json-events.md"
        );
        assert!(
            doc.contains(&format!("### `{name}`")),
            "no section for {name} in docs/json-events.md"
        );
    }
    assert!(messages >= 5, "examples of typed messages");
}

#[test]
fn listen_json_lines_match_the_schema() {
    let root = schema();
    let mut l = Listener::start(&[
        "--json",
        "--decode",
        "line",
        "--reply",
        "line ok",
        "--robot-reads",
        "ascii-float:3",
    ]);
    let mut s = robot(&l.addr);
    s.write_all("café\n".as_bytes()).unwrap();
    assert_eq!(read_line(&mut s), "ok\n");
    s.write_all(&[0xE9, b'\n']).unwrap();
    assert_eq!(read_line(&mut s), "ok\n");
    s.write_all(b"SET A 5\nGET A\n").unwrap();
    assert_eq!(read_line(&mut s), "A 5\n");
    s.write_all(b"GET NEVER\n").unwrap();
    assert_eq!(read_line(&mut s), "NEVER 0\n");
    s.write_all(b"SET A\n").unwrap();
    l.wait_for("\"var_invalid\"", false);
    let long = format!("{}\n", "x".repeat(5000));
    s.write_all(long.as_bytes()).unwrap();
    l.wait_for("\"decode_error\"", false);
    l.type_line("help");
    l.type_line("list");
    l.wait_for("\"list\"", false);
    l.type_line("@9 line hi");
    l.wait_for("\"error\"", false);
    l.type_line("floats 1 2 3");
    l.wait_for("\"operator\"", false);
    drop(s);
    let out = l.wait_for("\"close\"", false);
    let mut seen = Vec::new();
    for line in out.lines() {
        let v = check_event(&root, line);
        assert!(
            v["time"].is_string(),
            "listen events carry the wall clock: {line}"
        );
        seen.push(v["event"].as_str().unwrap().to_string());
    }
    for name in [
        "listening",
        "diagnosis",
        "connect",
        "rx",
        "decoded",
        "tx",
        "unknown_variable",
        "var_invalid",
        "decode_error",
        "help",
        "list",
        "error",
        "close",
    ] {
        assert!(
            seen.iter().any(|s| s == name),
            "no {name} event in {seen:?}"
        );
    }
}

#[test]
fn read_json_lines_match_the_schema() {
    let root = schema();
    let cases: [(&[&str], &[u8]); 6] = [
        (&["ascii-float", "2", "--repeat", "3"], b"(1,2)(3)(1e999,x)"),
        (
            &["binary-integer", "2", "--repeat", "2"],
            &[0, 0, 0, 7, 0xFF, 0xFF, 0xFF, 0xFF],
        ),
        (&["byte-list", "3"], &[1, 2]),
        (&["line", "--repeat", "2"], b"caf\xE9\r\nok"),
        (
            &["string", "--prefix", "<", "--suffix", ">"],
            "<café>".as_bytes(),
        ),
        (&["ascii-float", "6", "--timestamps"], b"p[1,2,3,0,0,0]"),
    ];
    let mut sentinels = 0;
    for (args, input) in cases {
        let mut all = vec!["read"];
        all.extend_from_slice(args);
        all.push("--json");
        let (code, out, err) = run(&all, input);
        assert_eq!(code, 0, "{all:?}: {err}");
        assert!(!out.is_empty(), "{all:?}");
        for line in out.lines() {
            let v = check_event(&root, line);
            assert_eq!(v["event"], "read", "{line}");
            if v["sentinel"] == true {
                sentinels += 1;
            }
        }
    }
    assert!(sentinels >= 2, "failed reads were among the cases");
}

#[test]
fn decode_json_lines_match_the_schema() {
    let root = schema();
    let cases: [(&[&str], &[u8]); 8] = [
        (&["line"], b"caf\xC3\xA9\ncaf\xE9\n"),
        (&["int32"], &[0, 0, 0, 100, 0xFF, 0xFF, 0xFF, 0xFE]),
        (&["byte"], &[0, 255]),
        (&["stx-etx"], b"\x02hi\x03\x02\xE9\x03"),
        (&["delimiter", "--delimiter", ";"], b"a;b;"),
        (&["var"], b"SET A -3\nGET B\n"),
        (
            &["value"],
            b"p[1, 2, 3, 4, 5, 6]\n[True, 2, 1.5]\n7\n2.5\nFalse\n",
        ),
        (&["value", "--allow-unterminated"], b"[]"),
    ];
    let mut types = Vec::new();
    for (args, input) in cases {
        let mut all = vec!["decode"];
        all.extend_from_slice(args);
        all.push("--json");
        let (code, out, err) = run(&all, input);
        assert_eq!(code, 0, "{all:?}: {err}");
        for line in out.lines() {
            let v = check_event(&root, line);
            assert_eq!(v["event"], "decoded", "{line}");
            assert!(v.get("conn").is_none(), "{line}");
            types.push(v["message"]["type"].as_str().unwrap().to_string());
        }
    }
    for t in [
        "line", "int32", "byte", "frame", "string", "set", "get", "pose", "list", "int", "float",
        "bool",
    ] {
        assert!(types.iter().any(|x| x == t), "no {t} message in {types:?}");
    }
}

#[test]
fn robot_json_lines_match_the_schema() {
    use std::io::{Read, Write};
    let root = schema();
    let server = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = server.local_addr().unwrap().port();
    let peer = std::thread::spawn(move || {
        let (mut s, _) = server.accept().unwrap();
        let mut b = [0u8; 64];
        let _ = s.read(&mut b);
        s.write_all(b"(1.5, 2)\nTRG\r\n").unwrap();
        std::thread::sleep(std::time::Duration::from_millis(300));
    });
    let script = format!(
        "ok = socket_open(\"127.0.0.1\", {port}, \"cam\")\n\
         socket_send_line(\"go\", \"cam\")\n\
         x = socket_read_ascii_float(2, \"cam\")\n\
         y = socket_read_line(\"cam\", timeout=0.1)\n\
         z = socket_read_byte_list(4, \"cam\", timeout=0.05)\n\
         textmsg(\"x = \", x)\n\
         popup(\"done\", \"Vision\", warning=True)\n\
         v = rq_pos()\n\
         socket_close(\"cam\")\n\
         socket_send_int(1, \"cam\")\n"
    );
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_ursock"))
        .args([
            "robot", "--json", "--trace", "--stub", "rq_pos=3", "-e", &script,
        ])
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap();
    peer.join().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    let mut kinds = Vec::new();
    for line in text.lines() {
        let v = check_event(&root, line);
        kinds.push(v["event"].as_str().unwrap().to_string());
    }
    for k in ["call", "message", "tx", "rx", "end"] {
        assert!(kinds.iter().any(|x| x == k), "{k} missing: {kinds:?}");
    }
    // The controller's own warning (a blend radius reduced: blends may not overlap).
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_ursock"))
        .args([
            "robot",
            "--json",
            "-e",
            "movel(p[-0.4, -0.2, 0.4, 0, 3.14, 0])\nmovel(p[-0.3, -0.2, 0.4, 0, 3.14, 0], r=0.08)\nmovel(p[-0.3, -0.18, 0.4, 0, 3.14, 0], r=0.08)\nmovel(p[-0.2, -0.18, 0.4, 0, 3.14, 0])",
        ])
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    let events: Vec<Value> = text.lines().map(|l| check_event(&root, l)).collect();
    let warning = events
        .iter()
        .find(|e| e["event"] == "message" && e["kind"] == "warning")
        .unwrap_or_else(|| panic!("no warning: {text}"));
    assert_eq!(warning["line"].as_u64(), Some(3));
    // Issue 30: every move is a move_start and a move_end (where the arm went, how the
    // move ended), every output change an output event.
    for e in &events {
        if e["event"] == "move_start" {
            assert_eq!(e["function"], "movel");
        }
    }
    let ends: Vec<&Value> = events.iter().filter(|e| e["event"] == "move_end").collect();
    assert_eq!(ends.len(), 4, "{text}");
    assert_eq!(ends[3]["outcome"], "reached");
    let pose = ends[3]["pose"].as_array().unwrap();
    assert!((pose[0].as_f64().unwrap() + 0.2).abs() < 1e-9, "{pose:?}");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_ursock"))
        .args([
            "robot",
            "--json",
            "-e",
            "set_tool_digital_out(0, True)\nset_standard_analog_out(1, 0.5)\nspeedj([0.1, 0, 0, 0, 0, 0], 1, 0.1)\nservoj([0, -1.5, 0, -1.5, 0, 0], t=0.1)\nmovej([0, -1.5, 0, -1.5, 0, 0.1])\nprotective_stop()",
        ])
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    let events: Vec<Value> = text.lines().map(|l| check_event(&root, l)).collect();
    let names: Vec<&str> = events.iter().filter_map(|e| e["event"].as_str()).collect();
    assert_eq!(
        names,
        [
            "output",
            "output",
            "move_start",
            "move_end",
            "move_start",
            "move_end",
            "move_start",
            "move_end",
            "error",
            "end"
        ],
        "{text}"
    );
    assert_eq!(events[0]["value"], true);
    assert_eq!(events[1]["value"], 0.5);
    assert_eq!(events[3]["outcome"], "replaced");
    assert_eq!(events[5]["outcome"], "reached");
    assert_eq!(events[9]["outcome"], "protective_stop");
    // A program error is an `error` event with its line and column, then `end`.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_ursock"))
        .args(["robot", "--json", "-e", "x = [1]\ny = x[2]"])
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    let events: Vec<Value> = text.lines().map(|l| check_event(&root, l)).collect();
    let err = events
        .iter()
        .find(|e| e["event"] == "error")
        .expect("error");
    assert_eq!(
        (err["line"].as_u64(), err["column"].as_u64()),
        (Some(2), Some(1))
    );
    assert_eq!(events.last().unwrap()["outcome"], "error");
}

/// `ursock controller --json` with only its dashboard server (on a free port); its
/// standard output piped, its standard input as given.
fn dashboard_only_controller(stdin: std::process::Stdio) -> std::process::Child {
    std::process::Command::new(env!("CARGO_BIN_EXE_ursock"))
        .args([
            "controller",
            "--dashboard-port",
            "0",
            "--no-streams",
            "--json",
        ])
        .stdin(stdin)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap()
}

#[test]
fn controller_json_lines_match_the_schema() {
    use std::io::{BufRead, BufReader, Write};
    let root = schema();
    let mut child = dashboard_only_controller(std::process::Stdio::null());
    let mut out = BufReader::new(child.stdout.take().unwrap());
    // `listening` events, `scheduling`, then `ready`: a client connects once the
    // controller is ready (a connection accepted earlier may be reported before `ready`).
    let mut addr = None;
    let mut kinds = Vec::new();
    loop {
        let mut l = String::new();
        assert!(out.read_line(&mut l).unwrap() > 0, "the output ended early");
        let v = check_event(&root, l.trim_end());
        if v["event"] == "listening" && v["service"] == "dashboard" {
            addr = v["addr"].as_str().map(str::to_string);
        }
        if v["event"] == "ready" {
            kinds.push("ready".to_string());
            break;
        }
    }
    let addr = addr.expect("a dashboard listening event before ready");
    {
        let s = std::net::TcpStream::connect(&addr).unwrap();
        s.set_read_timeout(Some(std::time::Duration::from_secs(20)))
            .unwrap();
        let mut r = BufReader::new(s.try_clone().unwrap());
        let mut w = s;
        let mut line = String::new();
        r.read_line(&mut line).unwrap(); // the greeting
        for cmd in ["robotmode", "power on", "no such command", "quit"] {
            w.write_all(format!("{cmd}\n").as_bytes()).unwrap();
            line.clear();
            r.read_line(&mut line).unwrap();
        }
    }
    // connect, 4 dashboard events, close: read them as they come (bounded).
    while kinds.len() < 7 {
        let mut l = String::new();
        if out.read_line(&mut l).unwrap() == 0 {
            break;
        }
        let v = check_event(&root, l.trim_end());
        if v["event"] == "dashboard" {
            assert!(v["reply"].as_array().is_some_and(|r| !r.is_empty()), "{l}");
        }
        // The loop's own reports and state changes (checked against the schema all the
        // same): lateness when the host is loaded, and `power on`'s change of the robot
        // mode.
        if ["late", "state"].contains(&v["event"].as_str().unwrap_or("")) {
            continue;
        }
        kinds.push(v["event"].as_str().unwrap().to_string());
    }
    let _ = child.kill();
    let _ = child.wait();
    assert_eq!(
        kinds,
        [
            "ready",
            "connect",
            "dashboard",
            "dashboard",
            "dashboard",
            "dashboard",
            "close"
        ]
    );
}

#[test]
fn client_json_lines_match_the_schema() {
    use std::io::Read;
    let root = schema();
    let device = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = device.local_addr().unwrap().to_string();
    let server = std::thread::spawn(move || {
        let (mut s, _) = device.accept().unwrap();
        s.set_read_timeout(Some(std::time::Duration::from_secs(20)))
            .unwrap();
        let mut got = [0u8; 5];
        s.read_exact(&mut got).unwrap();
        s.write_all(b"(1.5,2)\n").unwrap();
        got
    });
    let (code, out, err) = run(
        &["client", &addr, "--send", "ping", "--json", "--wait", "1"],
        b"",
    );
    assert_eq!(code, 0, "{err}");
    assert_eq!(&server.join().unwrap(), b"ping\n");
    let kinds: Vec<String> = out
        .lines()
        .map(|l| check_event(&root, l)["event"].as_str().unwrap().to_string())
        .collect();
    assert!(kinds.contains(&"tx".to_string()), "{kinds:?}");
    assert!(kinds.contains(&"rx".to_string()), "{kinds:?}");
}

#[test]
fn a_program_that_does_not_parse_reports_error_and_end_as_json() {
    let root = schema();
    let (code, out, _) = run(&["robot", "-e", "x = )", "--json"], b"");
    assert_eq!(code, 1);
    let events: Vec<Value> = out.lines().map(|l| check_event(&root, l)).collect();
    assert_eq!(events.len(), 2, "{out}");
    assert_eq!(events[0]["event"], "error");
    assert_eq!(
        (events[0]["line"].as_u64(), events[0]["column"].as_u64()),
        (Some(1), Some(5))
    );
    assert_eq!(events[1]["event"], "end");
    assert_eq!(events[1]["outcome"], "error");
}

/// The events of snippets, `@*` and `every` match the schema too (`origin` `periodic`,
/// multi-line notes).
#[test]
fn listen_snippet_all_and_periodic_events_match_the_schema() {
    let file = TempFile::new(
        "schema-snippets.txt",
        "tick = line T\nack = text OK\\r\\n\n",
    );
    let root = schema();
    let mut l = Listener::start(&["--json", "--snippets", file.path()]);
    let mut s = robot(&l.addr);
    l.wait_for("\"connect\"", false);
    l.type_line("snippets");
    l.type_line("@* $ack");
    assert_eq!(read_line(&mut s), "OK\r\n");
    l.type_line("every 0.02 $tick");
    assert_eq!(read_line(&mut s), "T\n");
    assert_eq!(read_line(&mut s), "T\n");
    l.wait_for("\"periodic\"", false);
    l.type_line("every off");
    let out = l.wait_for("stopped 1 periodic sends", false);
    let mut origins = Vec::new();
    for line in out.lines() {
        let v = check_event(&root, line);
        if let Some(o) = v["origin"].as_str() {
            origins.push(o.to_string());
        }
    }
    assert!(origins.iter().any(|o| o == "periodic"), "{origins:?}");
    assert!(out.contains("$2 ack = text OK"), "{out}");
}

#[test]
fn controller_operator_commands_and_state_changes_are_events_that_match_the_schema() {
    use std::io::{BufRead, BufReader, Write};
    let root = schema();
    let mut child = dashboard_only_controller(std::process::Stdio::piped());
    // Hang guard: the process ends after 20 s whatever happens, closing its output.
    let pid = child.id().to_string();
    std::thread::spawn(move || {
        std::thread::sleep(std::time::Duration::from_secs(20));
        let _ = std::process::Command::new("kill")
            .args(["-KILL", &pid])
            .status();
    });
    let mut stdin = child.stdin.take().unwrap();
    stdin
        .write_all(b"protective stop\nspeed 7\nstate\n")
        .unwrap();
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut operator = Vec::new();
    let mut states = Vec::new();
    while operator.len() < 3 || states.is_empty() {
        let mut l = String::new();
        if out.read_line(&mut l).unwrap() == 0 {
            break;
        }
        let v = check_event(&root, l.trim_end());
        if v["event"] == "operator" {
            operator.push(v);
        } else if v["event"] == "state" {
            states.push(v);
        }
    }
    // The protective stop is said as a change of state too.
    assert_eq!(
        states.first().map(|v| &v["safety"]),
        Some(&serde_json::json!("PROTECTIVE_STOP")),
        "{states:?}"
    );
    let _ = child.kill();
    let _ = child.wait();
    assert_eq!(operator.len(), 3, "{operator:?}");
    assert_eq!(operator[0]["command"], "protective stop");
    assert!(operator[0]["text"]
        .as_str()
        .unwrap()
        .contains("safety PROTECTIVE_STOP"));
    assert!(operator[1]["text"]
        .as_str()
        .unwrap()
        .starts_with("refused: "));
    assert_eq!(operator[2]["command"], "state");
}

/// Issue 30: the controller's program reports its moves and output changes as `robot`
/// does, in the same schema.
#[test]
fn controller_json_move_events_match_the_schema() {
    let root = schema();
    let c = Controller::start_checked(&[], move |l| check_event(&root, l));
    let _dashboard = c.power_on_and_release();
    let mut p = c.connect("primary");
    p.write_all(
        b"def go():\n  movej([0.5, -1.5, 1, -1, 0.2, 0], a=3, v=3)\n  set_standard_digital_out(1, True)\nend\n",
    )
    .unwrap();
    let mut seen = Vec::new();
    while !seen.iter().any(|v: &Value| v["event"] == "output") {
        let v = c.next_event();
        if matches!(
            v["event"].as_str(),
            Some("move_start" | "move_end" | "output")
        ) {
            seen.push(v);
        }
    }
    drop(c);
    let kinds: Vec<&str> = seen.iter().filter_map(|v| v["event"].as_str()).collect();
    assert_eq!(kinds, ["move_start", "move_end", "output"]);
    assert_eq!(seen[1]["outcome"], "reached");
    assert_eq!(seen[1]["joints"][0], 0.5);
    assert_eq!(seen[2]["pin"], 1);
}

/// `listen --robot FILE --json`: the virtual robot's calls, moves and outputs are events
/// of the schema, among the listener's own.
#[test]
fn listen_robot_json_lines_match_the_schema() {
    let root = schema();
    let program = TempFile::new(
        "listen-robot.script",
        "socket_send_line(\"hello\")\nmovej([0.5, -1.5, 1, -1, 0.2, 0], a=3, v=3, r=0)\nset_standard_digital_out(1, True)\n",
    );
    let listened = listen_common::output(&[
        "--decode",
        "line",
        "--exit-after",
        "1",
        "--json",
        "--robot",
        program.path(),
    ]);
    let out = String::from_utf8_lossy(&listened.stdout).into_owned();
    let err = String::from_utf8_lossy(&listened.stderr);
    assert_eq!(listened.status.code(), Some(0), "{err}");
    let events: Vec<Value> = out.lines().map(|l| check_event(&root, l)).collect();
    let at = |kind: &str| {
        events
            .iter()
            .position(|v| v["event"] == kind)
            .unwrap_or_else(|| panic!("no {kind} event:\n{out}"))
    };
    // The robot's call and the listener's decode of what it sent come from two threads:
    // both are there; the moves and the output come in the program's order.
    let _ = (at("call"), at("decoded"));
    assert!(
        at("move_start") < at("move_end") && at("move_end") < at("output"),
        "{out}"
    );
    let start = events
        .iter()
        .find(|v| v["event"] == "move_start")
        .expect(&out);
    assert_eq!(start["function"], "movej");
    assert_eq!(start["target_joints"][0], 0.5);
    let end = events
        .iter()
        .find(|v| v["event"] == "move_end")
        .expect(&out);
    assert_eq!(end["outcome"], "reached");
    assert!(end["took"].as_f64().unwrap() > 0.0, "{end}");
    assert!(end["time"].is_string(), "stamped as listen's events: {end}");
}

/// Issue 29: a program that pauses, stops or ends is said with the reason, in `program`
/// and `state` events of the schema: a client's new program replaced it, a dashboard
/// `pause` and `stop`, a runtime error (its message), a protective stop, its end.
#[test]
fn controller_json_says_why_a_program_paused_or_stopped() {
    let root = schema();
    let c = Controller::start_checked(&[], move |l| check_event(&root, l));
    let mut dashboard = c.power_on_and_release();
    let mut ask = |cmd: &str| dashboard.ask(cmd);
    let mut p = c.connect("primary");
    // The events up to the one `until` accepts, each checked against the schema.
    let upto = |until: &dyn Fn(&Value) -> bool| {
        let mut seen = Vec::new();
        loop {
            let v = c.next_event();
            let done = until(&v);
            if matches!(v["event"].as_str(), Some("program" | "state")) {
                seen.push(v);
            }
            if done {
                return seen;
            }
        }
    };
    let program = |what: &'static str, name: &'static str| {
        move |v: &Value| v["event"] == "program" && v["what"] == what && v["name"] == name
    };
    let state =
        |program: &'static str| move |v: &Value| v["event"] == "state" && v["program"] == program;
    p.write_all(b"def one():\n  sleep(30)\nend\n").unwrap();
    upto(&program("started", "one"));
    p.write_all(b"def two():\n  sleep(30)\nend\n").unwrap();
    let seen = upto(&program("started", "two"));
    let one = seen
        .iter()
        .find(|v| program("stopped", "one")(v))
        .expect("one stopped");
    assert_eq!(one["reason"], "replaced", "{one}");
    assert_eq!(ask("pause").trim(), "Pausing program");
    let seen = upto(&state("PAUSED"));
    assert_eq!(seen.last().unwrap()["reason"], "dashboard_pause");
    assert_eq!(ask("stop").trim(), "Stopped");
    let seen = upto(&state("STOPPED"));
    let two = seen
        .iter()
        .find(|v| program("stopped", "two")(v))
        .expect("two stopped");
    assert_eq!(two["reason"], "dashboard_stop", "{two}");
    assert_eq!(seen.last().unwrap()["reason"], "dashboard_stop");
    // A program that fails or stops in its first step: the `program` event says why.
    p.write_all(b"def three():\n  x = [1, 2]\n  y = x[5]\nend\n")
        .unwrap();
    let seen = upto(&program("error", "three"));
    let three = seen.last().unwrap();
    assert_eq!(three["reason"], "runtime_error", "{three}");
    assert!(
        three["text"].as_str().is_some_and(|t| t.contains("index")),
        "{three}"
    );
    p.write_all(b"def four():\n  protective_stop()\n  sleep(30)\nend\n")
        .unwrap();
    let seen = upto(&program("stopped", "four"));
    assert_eq!(seen.last().unwrap()["reason"], "protective_stop");
}
