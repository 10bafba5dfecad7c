//! The `.urp` translation is bounded in what it writes and in what it holds, not only in
//! the file's size: small files built to multiply their output (many External Control
//! nodes, a large reply, deep indentation, references repeating nodes) or their parsed
//! tree (many attributes) get a precise error naming the bound, never an abort.

use std::io::Write;

use urscript_controller::urp::{
    MAX_DEPTH, MAX_EXTERNAL_CONTROL_NODES, MAX_HOST_BYTES, MAX_NAME_BYTES, MAX_NODES_TRANSLATED,
    MAX_SCRIPT_BYTES, MAX_TREE_BYTES, MAX_XML_BYTES,
};
use urscript_controller::{read_urp, translate_with, UrpError};

const EC: &str = r#"<Contributed strategyClass="com.fzi.externalcontrol.ExternalControlNode" strategyProgramNodeType="External Control"><dataModel/></Contributed>"#;

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(bytes).unwrap();
    gz.finish().unwrap()
}

fn document(main: &str) -> String {
    format!(
        r#"<URProgram name="a" installation="default"><children><MainProgram runOnlyOnce="true"><children>{main}</children></MainProgram></children></URProgram>"#
    )
}

fn script_too_large(e: &UrpError) -> bool {
    matches!(
        e,
        UrpError::TooLarge { what: "translated script", limit } if *limit == MAX_SCRIPT_BYTES
    )
}

#[test]
fn a_reply_pasted_at_thousands_of_nodes_stops_at_the_script_bound() {
    // 2000 nodes in a file of about 1.4 KB; a 1 MB reply (2 GB pasted at every node).
    let file = gzip(document(&EC.repeat(2000)).as_bytes());
    assert!(file.len() < 2048, "{}", file.len());
    let program = read_urp(&file).unwrap();
    assert_eq!(program.external_control.len(), 2000);
    let reply = "textmsg(1)\n".repeat(95_325);
    let mut fetches = 0;
    let e = translate_with(&program, |_| {
        fetches += 1;
        Ok(reply.clone())
    })
    .unwrap_err();
    assert!(script_too_large(&e), "{e}");
    assert_eq!(
        e.to_string(),
        format!("the translated script is larger than {MAX_SCRIPT_BYTES} bytes")
    );
    assert_eq!(fetches, 1, "one request per program, as the URCap makes");
    // A few nodes with the same reply fit.
    let program = read_urp(document(&EC.repeat(3)).as_bytes()).unwrap();
    let script = translate_with(&program, |_| Ok(reply.clone())).unwrap();
    assert_eq!(script.matches("textmsg(1)").count(), 3 * 95_325);
}

#[test]
fn a_reply_of_empty_lines_deep_in_the_program_stops_at_the_script_bound() {
    // A node in 60 nested loops (122 bytes of indentation a line) and 16 MiB of empty
    // lines.
    let mut node = EC.to_string();
    for _ in 0..60 {
        node = format!(r#"<Loop type="Forever"><children>{node}</children></Loop>"#);
    }
    let file = gzip(document(&node).as_bytes());
    assert!(file.len() < 300, "{}", file.len());
    let program = read_urp(&file).unwrap();
    let reply = "\n".repeat((16 << 20) - 1);
    let e = translate_with(&program, |_| Ok(reply.clone())).unwrap_err();
    assert!(script_too_large(&e), "{e}");
    // The same node with a short reply.
    let script = translate_with(&program, |_| Ok("\n\nsync()\n".into())).unwrap();
    assert!(script.contains(&format!("{}sync()\n", " ".repeat(2 * 61 + 1))));
}

#[test]
fn elements_with_many_attributes_stop_at_the_tree_bound() {
    // 256 attributes per element (the most one may have): small compressed, far larger
    // as records. 12 000 of them (under half the XML bound) are over the tree bound.
    let attrs: String = (0..256).map(|k| format!(" a{k}=\"\"")).collect();
    let element = format!("<x{attrs}/>");
    let n = 12_000;
    assert!(n * element.len() < MAX_XML_BYTES / 2);
    let xml = format!(
        "<URProgram name=\"a\"><y>{}</y></URProgram>",
        element.repeat(n)
    );
    let file = gzip(xml.as_bytes());
    assert!(file.len() < 256 * 1024, "{}", file.len());
    let e = read_urp(&file).unwrap_err();
    assert_eq!(
        e,
        UrpError::TooLarge {
            what: "parsed document (estimated memory)",
            limit: MAX_TREE_BYTES
        },
        "{e}"
    );
}

#[test]
fn a_reference_to_an_enclosing_node_stops_at_the_depth_bound() {
    for main in [
        r#"<Folder><children><Folder reference="../.."/></children></Folder>"#,
        r#"<Move motionType="MoveJ"><children><Move reference="../.."/></children></Move>"#,
    ] {
        let e = read_urp(document(main).as_bytes()).unwrap_err();
        match &e {
            UrpError::Invalid { message, .. } => assert!(
                message.contains(&format!("nested deeper than {MAX_DEPTH}")),
                "{e}"
            ),
            other => panic!("{other:?}"),
        }
    }
}

#[test]
fn references_that_repeat_nodes_stop_at_the_node_bound() {
    // Level k holds two references to level k + 1: 2^40 uses of 80 elements. No line is
    // written (folders without a name), so only the count of nodes stops it.
    let levels = 40;
    let mut xml = String::new();
    for k in 0..levels {
        xml.push_str(&format!(
            r#"<Folder><children><Folder reference="../../../Folder[{n}]"/><Folder reference="../../../Folder[{n}]"/></children></Folder>"#,
            n = k + 2
        ));
    }
    xml.push_str("<Folder/>");
    let started = std::time::Instant::now();
    let e = read_urp(document(&xml).as_bytes()).unwrap_err();
    match &e {
        UrpError::Invalid { message, .. } => assert!(
            message.contains(&format!("more than {MAX_NODES_TRANSLATED} program nodes")),
            "{e}"
        ),
        other => panic!("{other:?}"),
    }
    // A hang guard, not a speed test.
    assert!(started.elapsed() < std::time::Duration::from_secs(60));
}

#[test]
fn a_large_node_repeated_by_references_stops_at_the_script_bound() {
    // One script line of 1 MB used 100 times through references.
    let line = format!(
        r#"<Script type="Line"><expression>textmsg("{}")</expression></Script>"#,
        "x".repeat(1 << 20)
    );
    let mut main = line;
    for _ in 0..100 {
        main.push_str(r#"<Script reference="../Script"/>"#);
    }
    let e = read_urp(document(&main).as_bytes()).unwrap_err();
    assert!(script_too_large(&e), "{e}");
}

#[test]
fn names_hosts_and_node_counts_are_bounded() {
    let long = "n".repeat(MAX_NAME_BYTES + 1);
    let e = read_urp(document(&format!("<{long}/>")).as_bytes()).unwrap_err();
    assert!(
        matches!(&e, UrpError::Xml { message, .. } if message.contains("element name longer than 256")),
        "{e}"
    );
    let e = read_urp(document(&format!("<Halt {long}=\"1\"/>")).as_bytes()).unwrap_err();
    assert!(
        matches!(&e, UrpError::Xml { message, .. } if message.contains("attribute name longer than 256")),
        "{e}"
    );

    let host = "h".repeat(MAX_HOST_BYTES + 1);
    let node = format!(
        r#"<Contributed strategyClass="com.fzi.externalcontrol.ExternalControlNode"><dataModel><entry key="host_ip" value="{host}"/></dataModel></Contributed>"#
    );
    let e = read_urp(document(&node).as_bytes()).unwrap_err();
    assert!(e.to_string().contains("a host name of 256 bytes"), "{e}");
    let installation = format!(
        r#"<Installation><Contributed ownerId="com.fzi.externalcontrol"><data key="host_ip" value="{host}"/></Contributed></Installation>"#
    );
    let e =
        urscript_controller::read_external_control_settings(installation.as_bytes()).unwrap_err();
    assert!(e.to_string().contains("a host name of 256 bytes"), "{e}");

    let e = read_urp(document(&EC.repeat(MAX_EXTERNAL_CONTROL_NODES + 1)).as_bytes()).unwrap_err();
    assert!(
        e.to_string().contains(&format!(
            "more than {MAX_EXTERNAL_CONTROL_NODES} External Control nodes"
        )),
        "{e}"
    );
    assert_eq!(
        read_urp(document(&EC.repeat(MAX_EXTERNAL_CONTROL_NODES)).as_bytes())
            .unwrap()
            .external_control
            .len(),
        MAX_EXTERNAL_CONTROL_NODES
    );
}
