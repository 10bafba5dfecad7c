//! `.urp` reading and translation. Every `.urp` here is written by the test itself: the
//! XML modelled on the structure PolyScope saves, gzip-compressed with flate2.

use std::io::Write;
use std::time::Duration;

use proptest::prelude::*;
use urscript_controller::urp::{MAX_DEPTH, MAX_ELEMENTS, MAX_URP_BYTES, MAX_XML_BYTES};
use urscript_controller::{read_urp, translate_with, FetchError, UrpError, UrpProgram};
use urscript_interp::{Config, Event, Machine, MessageKind, Program, State};

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(bytes).unwrap();
    gz.finish().unwrap()
}

/// An expression as PolyScope saves it: one `<ExpressionChar>` per character.
fn expr(text: &str) -> String {
    let mut out = String::from("<expression>");
    for c in text.chars() {
        let c = match c {
            '"' => "&quot;".to_string(),
            '<' => "&lt;".to_string(),
            '>' => "&gt;".to_string(),
            '&' => "&amp;".to_string(),
            c => c.to_string(),
        };
        out.push_str(&format!("<ExpressionChar character=\"{c}\"/>"));
    }
    out.push_str("</expression>");
    out
}

fn script_line(text: &str) -> String {
    format!("<Script type=\"Line\">{}</Script>", expr(text))
}

fn document(name: &str, run_once: bool, main: &str, extra: &str) -> String {
    format!(
        r#"<URProgram name="{name}" installation="default" installationRelativePath="default" directory="/programs" createdIn="5.11.0" lastSavedIn="5.11.0" robotSerialNumber="20000000000" crcValue="1">
  <kinematics status="NOT_INITIALIZED" validChecksum="false">
    <deltaTheta value="0.0, 0.0, 0.0, 0.0, 0.0, 0.0"/>
  </kinematics>
  <children>
    <InitVariablesNode/>
    {extra}
    <MainProgram runOnlyOnce="{run_once}" InitVariablesNode="false">
      <children>
{main}
      </children>
    </MainProgram>
  </children>
</URProgram>"#
    )
}

fn urp(main: &str) -> Vec<u8> {
    gzip(document("test", true, main, "").as_bytes())
}

fn read(main: &str) -> UrpProgram {
    let program = read_urp(&urp(main)).unwrap_or_else(|e| panic!("{e}"));
    if let Err(e) = Program::parse(&program.script) {
        panic!("{e:?}\n{}", program.script);
    }
    program
}

fn machine(script: &str) -> Machine {
    let program = Program::parse(script).unwrap_or_else(|e| panic!("{e:?}\n{script}"));
    Machine::new(program, Config::default())
}

/// Runs until `until` (virtual time) and returns the messages shown.
fn run(m: &mut Machine, until: Duration) -> Vec<(MessageKind, String)> {
    m.run_until(until);
    std::iter::from_fn(|| m.poll_event())
        .filter_map(|e| match e {
            Event::Message(msg) => Some((msg.kind, msg.text)),
            _ => None,
        })
        .collect()
}

fn texts(messages: &[(MessageKind, String)]) -> Vec<&str> {
    messages.iter().map(|(_, t)| t.as_str()).collect()
}

fn waypoint(name: &str, q: [f64; 6], params: &str) -> String {
    let q: Vec<String> = q.iter().map(|x| x.to_string()).collect();
    format!(
        r#"<Waypoint type="Fixed" name="{name}" kinematicsFlags="4">
  <motionParameters {params}/>
  <position>
    <JointAngles angles="{}"/>
    <TCPOffset pose="0.0, 0.0, 0.0, 0.0, 0.0, 0.0"/>
    <Kinematics status="NOT_INITIALIZED" validChecksum="false"/>
  </position>
  <BaseToFeature pose="0.0, 0.0, 0.0, 0.0, 0.0, 0.0"/>
</Waypoint>"#,
        q.join(", ")
    )
}

const Q1: [f64; 6] = [0.1, -1.5, 1.4, -1.5, -1.57, 0.2];
const Q2: [f64; 6] = [0.2, -1.4, 1.3, -1.5, -1.57, 0.2];

#[test]
fn a_program_with_every_node_runs_as_polyscope_would() {
    let main = format!(
        r#"
<Comment comment="set up"/>
<Assignment valueSource="Expression"><variable name="count" prefersPersistentValue="false"/>{zero}</Assignment>
<Loop type="Counting" count="3">
  <children>
    <Assignment valueSource="Expression"><variable reference="../../../../Assignment/variable"/>{incr}</Assignment>
    {tick}
  </children>
</Loop>
<If type="If" checkContinuously="false">{is2}<children>{two}</children></If>
<If type="ElseIf">{is3}<children>{three}</children></If>
<If type="Else"><children>{other}</children></If>
<Folder name="outputs">
  <children>
    <Set type="DigitalOutput"><pin referencedName="digital_out[2]"/><digitalValue>1</digitalValue></Set>
    <Set type="AnalogOutput"><pin referencedName="analog_out[1]"/><analogValue>0.25</analogValue></Set>
    <Set type="Expression"><pin referencedName="tool_out[1]"/>{count3}</Set>
  </children>
</Folder>
<Wait type="Sleep"><waitTime>0.1</waitTime></Wait>
{after_sleep}
<Wait type="DigitalInput"><pin referencedName="digital_in[1]"/><digitalValue>1</digitalValue></Wait>
{after_input}
<Move motionType="MoveJ" speed="1.0471975511965976" acceleration="1.3962634015954636" useActiveTCP="false">
  <feature class="GeomFeatureReference" referencedName="Base"/>
  <children>{w1}</children>
</Move>
<Move motionType="MoveL" speed="0.25" acceleration="1.2" useActiveTCP="false">
  <children>{w2}</children>
</Move>
<Popup type="Message" haltProgram="false" message="all &quot;done&quot;"/>
"#,
        zero = expr("0"),
        incr = expr("count + 1"),
        tick = script_line("textmsg(\"tick \", count)"),
        is2 = expr("count == 2"),
        is3 = expr("count == 3"),
        two = script_line("textmsg(\"two\")"),
        three = script_line("textmsg(\"three\")"),
        other = script_line("textmsg(\"other\")"),
        count3 = expr("count == 3"),
        after_sleep = script_line("textmsg(\"slept\")"),
        after_input = script_line("textmsg(\"input\")"),
        w1 = waypoint("Waypoint_1", Q1, ""),
        w2 = waypoint(
            "Waypoint_2",
            Q2,
            r#"cartesianSpeed="0.1" blendRadius="0.0""#
        ),
    );
    let program = read(&main);
    assert_eq!(program.name, "test");
    assert_eq!(program.installation, "default");
    assert_eq!(program.created_in.as_deref(), Some("5.11.0"));
    assert!(program.external_control.is_empty());
    let s = &program.script;
    assert!(s.starts_with("def test():\n"), "{s}");
    assert!(s.contains("\n  # set up\n"), "{s}");
    assert!(s.contains("\n  global count = 0\n"), "{s}");
    assert!(s.contains("\n  if (count == 2):\n"), "{s}");
    assert!(s.contains("\n  elif (count == 3):\n"), "{s}");
    assert!(s.contains("\n  else:\n"), "{s}");
    assert!(s.contains("set_standard_digital_out(2, True)"), "{s}");
    assert!(s.contains("set_standard_analog_out(1, 0.25)"), "{s}");
    assert!(s.contains("set_tool_digital_out(1, count == 3)"), "{s}");
    assert!(
        s.contains("while (not(get_standard_digital_in(1) == True)):"),
        "{s}"
    );
    assert!(
        s.contains(
            "movej([0.1, -1.5, 1.4, -1.5, -1.57, 0.2], a=1.3962634015954636, v=1.0471975511965976)"
        ),
        "{s}"
    );
    assert!(s.contains("movel(get_forward_kin([0.2, -1.4, 1.3, -1.5, -1.57, 0.2], p[0.0, 0.0, 0.0, 0.0, 0.0, 0.0]), a=1.2, v=0.1)"), "{s}");
    assert!(
        s.contains("popup('all \"done\"', \"Message\", False, False, blocking=True)"),
        "{s}"
    );
    assert!(s.ends_with("end\n"));

    let mut m = machine(s);
    let first = run(&mut m, Duration::from_millis(500));
    assert_eq!(
        texts(&first),
        ["tick 1", "tick 2", "tick 3", "three", "slept"]
    );
    assert_eq!(m.state(), &State::Running, "waits for digital_in[1]");
    assert!(m.arm().digital_out[2]);
    assert!(m.arm().tool_out[1]);
    assert_eq!(m.arm().analog_out[1], 0.25);
    m.world_mut().digital_in[1] = true;
    let rest = run(&mut m, Duration::from_secs(30));
    assert_eq!(m.state(), &State::Finished);
    assert_eq!(texts(&rest), ["input", "all \"done\""]);
    assert!(matches!(
        rest[1].0,
        MessageKind::Popup {
            warning: false,
            error: false,
            ..
        }
    ));
    let q = m.joint_positions();
    for (got, want) in q.iter().zip(Q2) {
        assert!((got - want).abs() < 1e-6, "joints {q:?}, want {Q2:?}");
    }
}

#[test]
fn a_popup_that_halts_and_a_halt_node_stop_the_program() {
    let main = format!(
        r#"<Popup type="Error" haltProgram="true" message="gripper lost"/>{}"#,
        script_line("textmsg(\"never\")")
    );
    let p = read(&main);
    let mut m = machine(&p.script);
    let shown = run(&mut m, Duration::from_secs(1));
    assert_eq!(m.state(), &State::Halted);
    assert_eq!(texts(&shown), ["gripper lost"]);
    assert!(
        matches!(&shown[0].0, MessageKind::Popup { error: true, title, .. } if title == "Error")
    );

    let p = read(&format!("<Halt/>{}", script_line("textmsg(\"never\")")));
    let mut m = machine(&p.script);
    assert!(run(&mut m, Duration::from_secs(1)).is_empty());
    assert_eq!(m.state(), &State::Halted);
}

#[test]
fn a_program_that_loops_forever_repeats_its_nodes() {
    let xml = document(
        "loops",
        false,
        &format!(
            "{}<Wait type=\"Sleep\"><waitTime>0.1</waitTime></Wait>",
            script_line("textmsg(\"round\")")
        ),
        r#"<SpecialSequence type="BeforeStart"><children>
             <Script type="Line"><expression>textmsg("before")</expression></Script>
           </children></SpecialSequence>"#,
    );
    let p = read_urp(&gzip(xml.as_bytes())).unwrap();
    assert!(
        p.script
            .contains("\n  while (True):\n    textmsg(\"round\")\n"),
        "{}",
        p.script
    );
    let mut m = machine(&p.script);
    let shown = run(&mut m, Duration::from_millis(350));
    assert_eq!(
        texts(&shown),
        ["before", "round", "round", "round", "round"]
    );
    assert_eq!(m.state(), &State::Running);
}

#[test]
fn loops_while_an_expression_and_waits_for_one() {
    let main = format!(
        r#"<Assignment><variable name="i"/>{zero}</Assignment>
<Loop type="While">{cond}<children>
  <Assignment><variable name="i"/>{incr}</Assignment>
  <Wait type="Sleep"><waitTime>0.01</waitTime></Wait>
</children></Loop>
<Wait type="Expression">{ready}</Wait>
{done}
<Loop type="Forever"><children><Halt/></children></Loop>"#,
        zero = expr("0"),
        cond = expr("i < 5"),
        incr = expr("i + 1"),
        ready = expr("i >= 5"),
        done = script_line("textmsg(\"i = \", i)"),
    );
    let p = read(&main);
    assert!(p.script.contains("while (i < 5):"), "{}", p.script);
    assert!(
        p.script.contains("while (not(i >= 5)):\n    sync()\n  end"),
        "{}",
        p.script
    );
    let mut m = machine(&p.script);
    let shown = run(&mut m, Duration::from_secs(1));
    assert_eq!(texts(&shown), ["i = 5"]);
    assert_eq!(m.state(), &State::Halted);
}

#[test]
fn script_files_run_their_cached_contents_line_by_line() {
    let main = r#"<Script type="File">
  <cachedContents>def greet(who):
  textmsg("hello ", who)
end
greet("file")
</cachedContents>
  <file resolves-to="file">/programs/greet.script</file>
</Script>"#;
    let p = read(main);
    let mut m = machine(&p.script);
    assert_eq!(texts(&run(&mut m, Duration::from_secs(1))), ["hello file"]);
    assert_eq!(m.state(), &State::Finished);

    let missing = r#"<Script type="File"><file>/programs/x.script</file></Script>"#;
    match read_urp(&urp(missing)) {
        Err(UrpError::Invalid { path, message }) => {
            assert_eq!(path, "URProgram/children/MainProgram/children/Script");
            assert!(message.contains("/programs/x.script"), "{message}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn sub_programs_are_defined_once_and_called_where_the_calls_are() {
    let main = format!(
        r#"<CallSubProgram>
  <subprogram name="Pick part" keepHidden="false" keepSynchronizedWithDisk="false">
    <children>{}</children>
  </subprogram>
</CallSubProgram>
<CallSubProgram><subprogram reference="../../CallSubProgram/subprogram"/></CallSubProgram>"#,
        script_line("textmsg(\"picked\")")
    );
    let p = read(&main);
    assert_eq!(
        p.script.matches("def Pick_part():").count(),
        1,
        "{}",
        p.script
    );
    assert_eq!(
        p.script.matches("  Pick_part()\n").count(),
        2,
        "{}",
        p.script
    );
    let mut m = machine(&p.script);
    assert_eq!(
        texts(&run(&mut m, Duration::from_secs(1))),
        ["picked", "picked"]
    );
}

#[test]
fn an_if_else_nested_in_an_if_is_its_own_chain() {
    // As PolyScope saves it: ElseIf/Else are siblings after their If (their own
    // `<expression/>` empty for an Else), also inside another If's children.
    let main = format!(
        r#"<If type="If" checkContinuously="false">{outer}<children>
  <If type="If" checkContinuously="false">{inner}<children>{yes}</children></If>
  <If type="Else" checkContinuously="false"><expression/><children>{no}</children></If>
  {after}
</children></If>
<If type="ElseIf" checkContinuously="false">{never}<children>{x}</children></If>"#,
        outer = expr("True"),
        inner = expr("get_standard_digital_in(0) \u{225f} True"),
        yes = script_line("textmsg(\"on\")"),
        no = script_line("textmsg(\"off\")"),
        after = script_line("textmsg(\"after\")"),
        never = expr("False"),
        x = script_line("textmsg(\"x\")"),
    );
    let p = read(&main);
    assert!(
        p.script
            .contains("if (get_standard_digital_in(0) == True):"),
        "{}",
        p.script
    );
    let mut m = machine(&p.script);
    assert_eq!(
        texts(&run(&mut m, Duration::from_secs(1))),
        ["off", "after"]
    );

    let orphan = format!(
        r#"<If type="Else"><children>{}</children></If>"#,
        script_line("x = 1")
    );
    assert!(matches!(
        read_urp(&urp(&orphan)),
        Err(UrpError::Invalid { .. })
    ));
    let twice = format!(
        r#"<If type="If">{c}<children/></If><If type="Else"><children/></If><If type="Else"><children/></If>"#,
        c = expr("True")
    );
    assert!(
        matches!(read_urp(&urp(&twice)), Err(UrpError::Invalid { message, .. }) if message.contains("after Else"))
    );
}

#[test]
fn variables_in_expressions_are_references_to_their_assignment() {
    // 5.x: <ExpressionVariable><ProgramVariable reference=".../variable"/></ExpressionVariable>,
    // words as <ExpressionToken token=" and "/>.
    let main = r#"<Assignment valueSource="Expression">
  <variable name="ready" prefersPersistentValue="false"><initializeExpression/></variable>
  <expression><ExpressionToken token=" True "/></expression>
</Assignment>
<Loop type="While" checkContinuously="false">
  <expression>
    <ExpressionVariable><ProgramVariable reference="../../../../Assignment/variable"/></ExpressionVariable>
    <ExpressionChar character="&#x225f;"/>
    <ExpressionToken token=" True "/>
    <ExpressionToken token=" and "/>
    <ExpressionChar character="1"/><ExpressionChar character="&#x2264;"/><ExpressionChar character="2"/>
  </expression>
  <children>
    <Assignment valueSource="Expression">
      <variable reference="../../../../Assignment/variable"/>
      <expression><ExpressionToken token=" False "/></expression>
    </Assignment>
    <Script type="Line"><expression><ExpressionChar character="t"/><ExpressionChar character="e"/><ExpressionChar character="x"/><ExpressionChar character="t"/><ExpressionChar character="m"/><ExpressionChar character="s"/><ExpressionChar character="g"/><ExpressionChar character="("/><ExpressionVariable><ProgramVariable reference="../../../../../../Assignment/variable"/></ExpressionVariable><ExpressionChar character=")"/></expression></Script>
  </children>
</Loop>"#;
    let p = read(main);
    assert!(
        p.script.contains("while (ready== True  and 1<=2):"),
        "{}",
        p.script
    );
    assert!(p.script.contains("global ready =  False "), "{}", p.script);
    let mut m = machine(&p.script);
    assert_eq!(texts(&run(&mut m, Duration::from_secs(1))), ["False"]);
    assert_eq!(m.state(), &State::Finished);

    let nothing =
        r#"<Wait type="Expression"><expression><ExpressionVariable/></expression></Wait>"#;
    assert!(matches!(
        read_urp(&urp(nothing)),
        Err(UrpError::Invalid { .. })
    ));
}

const EC: &str = r#"<Contributed strategyClass="com.fzi.externalcontrol.ExternalControlNode" strategyProgramNodeType="External Control"><dataModel/></Contributed>"#;

#[test]
fn external_control_nodes_get_the_fetched_script_header_once() {
    let main = format!("{EC}{}{EC}", script_line("textmsg(\"between\")"));
    let p = read(&main);
    assert_eq!(p.external_control.len(), 2);
    assert_eq!(p.external_control[0].host, "192.168.56.1");
    assert_eq!(p.external_control[0].port, 50002);
    assert_eq!(
        p.external_control[1].path,
        "URProgram/children/MainProgram/children/Contributed[2]"
    );
    let reply =
        "# HEADER_BEGIN\r\ndef control():\n  textmsg(\"control\")\nend\n# HEADER_END\ncontrol()\n";
    let mut calls = 0;
    let script = translate_with(&p, |node| {
        calls += 1;
        assert_eq!(node.index, 0);
        Ok(reply.to_string())
    })
    .unwrap();
    assert_eq!(calls, 1, "the URCap asks once per program");
    assert_eq!(script.matches("def control():").count(), 1, "{script}");
    assert_eq!(script.matches("   control()\n").count(), 2, "{script}");
    let mut m = machine(&script);
    assert_eq!(
        texts(&run(&mut m, Duration::from_secs(1))),
        ["control", "between", "control"]
    );

    // No header markers: all of the reply is the control loop, at every node.
    let script = translate_with(&p, |_| Ok("textmsg(\"loop\")".to_string())).unwrap();
    let mut m = machine(&script);
    assert_eq!(
        texts(&run(&mut m, Duration::from_secs(1))),
        ["loop", "between", "loop"]
    );

    // Markers must stand alone on their line (spaces around them only, as the URCap
    // matches them); lines before the header are dropped, as the URCap drops them.
    let reply = "textmsg(\"dropped\")\n\t# HEADER_BEGIN\n# HEADER_BEGIN  \ndef c2():\n  textmsg(\"c2\")\nend\n# HEADER_END\nc2()\n";
    let script = translate_with(&p, |_| Ok(reply.to_string())).unwrap();
    assert!(!script.contains("dropped"), "{script}");
    let mut m = machine(&script);
    assert_eq!(
        texts(&run(&mut m, Duration::from_secs(1))),
        ["c2", "between", "c2"]
    );

    // A host that cannot be reached: the URCap's error popup.
    let mut p = p;
    p.set_external_control_host("10.0.0.7", 50010);
    let script = translate_with(&p, |node| {
        assert_eq!((node.host.as_str(), node.port), ("10.0.0.7", 50010));
        Err(FetchError::Connect("Connection refused".to_string()))
    })
    .unwrap();
    let mut m = machine(&script);
    let shown = run(&mut m, Duration::from_secs(1));
    assert_eq!(shown.len(), 3);
    assert_eq!(
        shown[0].1,
        "The connection to the remote PC at 10.0.0.7:50010 could not be established. Reason: Connection refused"
    );
    assert!(
        matches!(&shown[0].0, MessageKind::Popup { error: true, title, .. } if title == "Receive program failed")
    );

    let script = translate_with(&p, |_| Err(FetchError::Timeout)).unwrap();
    let mut m = machine(&script);
    let shown = run(&mut m, Duration::from_secs(1));
    assert_eq!(
        shown[0].1,
        "Timeout while reading requested program from 10.0.0.7:50010"
    );
}

#[test]
fn external_control_host_and_port_from_the_node_data() {
    let node = r#"<Contributed strategyClass="com.ur.urcap.externalcontrol.Node" strategyProgramNodeType="External Control"><dataModel><data key="host_ip" value="10.1.2.3"/><data key="port_nr" value="50007"/><data key="maxlostpackages" value="1000"/></dataModel></Contributed>"#;
    let p = read(node);
    assert_eq!(p.external_control[0].host, "10.1.2.3");
    assert_eq!(p.external_control[0].port, 50007);
    assert_eq!(p.external_control[0].data.len(), 3);
    assert!(
        p.script.contains("# External Control node 0"),
        "{}",
        p.script
    );
}

#[test]
fn uncompressed_programs_are_read_too() {
    let xml = document("plain", true, &script_line("textmsg(\"plain\")"), "");
    let p = read_urp(xml.as_bytes()).unwrap();
    assert_eq!(p.script, "def plain():\n  textmsg(\"plain\")\nend\n");
}

#[test]
fn unknown_nodes_are_errors_naming_them() {
    match read_urp(&urp(
        "<Wait type=\"Sleep\"><waitTime>1</waitTime></Wait><Gripper force=\"3\"/>",
    )) {
        Err(UrpError::UnknownNode { name, path }) => {
            assert_eq!(name, "Gripper");
            assert_eq!(path, "URProgram/children/MainProgram/children/Gripper");
        }
        other => panic!("{other:?}"),
    }
    let rg = r#"<Contributed strategyClass="com.onrobot.urcap.RG" strategyProgramNodeType="RG Grip"><dataModel/></Contributed>"#;
    match read_urp(&urp(rg)) {
        Err(UrpError::UnknownNode { name, .. }) => assert_eq!(name, "Contributed (RG Grip)"),
        other => panic!("{other:?}"),
    }
    let token = "<Wait type=\"Expression\"><expression><ExpressionWaypoint/></expression></Wait>";
    assert!(
        matches!(read_urp(&urp(token)), Err(UrpError::UnknownNode { name, .. }) if name == "ExpressionWaypoint")
    );
    let relative =
        r#"<Move motionType="MoveL"><children><Waypoint type="Relative"/></children></Move>"#;
    assert!(matches!(
        read_urp(&urp(relative)),
        Err(UrpError::Unsupported { .. })
    ));
    let continuous = format!(
        r#"<If type="If" checkContinuously="true">{}<children/></If><If type="Else"><children/></If>"#,
        expr("True")
    );
    assert!(
        matches!(read_urp(&urp(&continuous)), Err(UrpError::Unsupported { what, .. }) if what.contains("continuously"))
    );
    let circle = r#"<Move motionType="MoveC"><children/></Move>"#;
    assert!(matches!(
        read_urp(&urp(circle)),
        Err(UrpError::Unsupported { .. })
    ));
    let bad_time = "<Wait type=\"Sleep\"><waitTime>soon</waitTime></Wait>";
    assert!(
        matches!(read_urp(&urp(bad_time)), Err(UrpError::Invalid { message, .. }) if message.contains("soon"))
    );
}

#[test]
fn broken_input_is_a_typed_error() {
    assert_eq!(read_urp(b"").unwrap_err(), UrpError::NotGzip);
    assert_eq!(
        read_urp(b"PK\x03\x04 a zip").unwrap_err(),
        UrpError::NotGzip
    );
    assert!(matches!(
        read_urp(&gzip(b"hello")),
        Err(UrpError::Xml { .. })
    ));
    assert!(matches!(
        read_urp(&gzip(b"<a><b></a>")),
        Err(UrpError::Xml { .. })
    ));
    assert!(
        matches!(read_urp(&gzip(b"<Installation name=\"x\"/>")), Err(UrpError::NotAProgram { root }) if root == "Installation")
    );
    assert!(matches!(
        read_urp(&gzip(b"<URProgram name=\"x\"/><URProgram/>")),
        Err(UrpError::Xml { .. })
    ));
    assert!(matches!(
        read_urp(&gzip(b"<URProgram>&bogus;</URProgram>")),
        Err(UrpError::Xml { .. })
    ));

    // Truncated: the gzip stream, or a whole stream of half a document.
    let full = urp(&script_line("textmsg(\"x\")"));
    assert!(matches!(
        read_urp(&full[..full.len() / 2]),
        Err(UrpError::Gzip { .. })
    ));
    let xml = document("t", true, &script_line("textmsg(\"x\")"), "");
    assert!(matches!(
        read_urp(&gzip(&xml.as_bytes()[..xml.len() / 2])),
        Err(UrpError::Xml { .. })
    ));
    let cut = xml.find("</MainProgram>").unwrap();
    match read_urp(&gzip(&xml.as_bytes()[..cut])) {
        Err(UrpError::Xml { offset, message }) => {
            assert_eq!(offset, cut as u64);
            assert!(message.contains("ends inside <MainProgram>"), "{message}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_gzip_bomb_stops_at_the_bound() {
    // gzip members one after another inflate to their concatenation (as gunzip reads
    // them): one member of 1 MiB of blanks, repeated past the bound.
    let mut bomb = gzip(b"<URProgram name=\"bomb\">");
    let member = gzip(&vec![b' '; 1 << 20]);
    for _ in 0..(MAX_XML_BYTES >> 20) + 1 {
        bomb.extend_from_slice(&member);
    }
    assert!(bomb.len() < 1 << 20, "the bomb is small: {}", bomb.len());
    assert!(
        matches!(read_urp(&bomb), Err(UrpError::TooLarge { limit, .. }) if limit == MAX_XML_BYTES)
    );

    // Under the bound, members are read whole.
    let xml = document("two", true, &script_line("textmsg(\"x\")"), "");
    let (a, b) = xml.as_bytes().split_at(xml.len() / 2);
    let mut two = gzip(a);
    two.extend_from_slice(&gzip(b));
    assert_eq!(read_urp(&two).unwrap().name, "two");

    let huge = vec![b'<'; MAX_URP_BYTES + 1];
    assert!(matches!(
        read_urp(&huge),
        Err(UrpError::TooLarge { what: "file", .. })
    ));
}

#[test]
fn nesting_and_element_count_are_bounded() {
    let mut deep = String::new();
    for _ in 0..MAX_DEPTH {
        deep.push_str("<Folder><children>");
    }
    for _ in 0..MAX_DEPTH {
        deep.push_str("</children></Folder>");
    }
    assert!(
        matches!(read_urp(&urp(&deep)), Err(UrpError::TooDeep { limit, .. }) if limit == MAX_DEPTH)
    );

    // Nesting within the bound translates (a few folders deep).
    let mut ok = String::new();
    for _ in 0..10 {
        ok.push_str("<Folder><children>");
    }
    ok.push_str(&script_line("textmsg(\"deep\")"));
    for _ in 0..10 {
        ok.push_str("</children></Folder>");
    }
    assert!(read(&ok).script.contains("textmsg(\"deep\")"));

    let many = document("many", true, &"<Halt/>".repeat(MAX_ELEMENTS), "");
    assert!(
        matches!(read_urp(many.as_bytes()), Err(UrpError::TooManyElements { limit, .. }) if limit == MAX_ELEMENTS)
    );
}

#[test]
fn references_that_do_not_resolve_or_loop_are_errors() {
    let dangling =
        r#"<CallSubProgram><subprogram reference="../../Nothing/subprogram"/></CallSubProgram>"#;
    assert!(
        matches!(read_urp(&urp(dangling)), Err(UrpError::Invalid { message, .. }) if message.contains("does not resolve"))
    );
    let selfref = r#"<CallSubProgram><subprogram reference="."/></CallSubProgram>"#;
    assert!(
        matches!(read_urp(&urp(selfref)), Err(UrpError::Invalid { message, .. }) if message.contains("chained"))
    );
    let up =
        r#"<CallSubProgram><subprogram reference="../../../../../../../.."/></CallSubProgram>"#;
    assert!(matches!(read_urp(&urp(up)), Err(UrpError::Invalid { .. })));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
        let _ = read_urp(&bytes);
        let _ = read_urp(&gzip(&bytes));
    }

    #[test]
    fn damaged_programs_never_panic(
        at in 0usize..4096,
        with in proptest::collection::vec(any::<u8>(), 1..8),
        cut in 0usize..4096,
    ) {
        let main = format!(
            "{}<Loop type=\"Counting\" count=\"2\"><children>{}</children></Loop>{EC}",
            script_line("textmsg(\"a\")"),
            waypoint("w", Q1, "")
        );
        let mut xml = document("d", true, &main, "").into_bytes();
        let at = at % xml.len();
        let end = (at + with.len()).min(xml.len());
        xml.splice(at..end, with);
        xml.truncate(xml.len() - cut % xml.len());
        if let Ok(p) = read_urp(&gzip(&xml)) {
            let _ = translate_with(&p, |_| Ok(String::from("textmsg(1)")));
        }
    }
}

#[test]
fn the_installation_gives_the_external_control_host_and_port() {
    use urscript_controller::{read_external_control_settings, ExternalControlSettings};
    let installation = r#"<Installation INSTALLATION-VERSION="2" directory="/programs" fileName="default">
  <IOs><DigitalInputNames value=", , "/></IOs>
  <Contributions>
    <URCaps>
      <Contributed ownerId="com.example.other" id="Other" name="Other"/>
      <Contributed ownerId="com.fzi.externalcontrol" id="com.fzi.externalcontrol.impl.ExternalControlInstallationNodeService" name="External Control">
        <data key="name" value="driver PC"/>
        <data key="host_ip" value="172.17.0.1"/>
        <data key="port_nr" value="50012"/>
      </Contributed>
    </URCaps>
  </Contributions>
</Installation>"#;
    let s = read_external_control_settings(&gzip(installation.as_bytes())).unwrap();
    assert_eq!(
        s,
        ExternalControlSettings {
            host: "172.17.0.1".into(),
            port: 50012,
            installed: true
        }
    );

    let without = "<Installation><Contributions><URCaps/></Contributions></Installation>";
    let s = read_external_control_settings(without.as_bytes()).unwrap();
    assert_eq!(s, ExternalControlSettings::default());
    assert_eq!(
        (s.host.as_str(), s.port, s.installed),
        ("192.168.56.1", 50002, false)
    );

    let bad_port = installation.replace("50012", "fifty");
    assert!(matches!(
        read_external_control_settings(bad_port.as_bytes()),
        Err(UrpError::Invalid { message, .. }) if message.contains("fifty")
    ));
    assert!(matches!(
        read_external_control_settings(&urp("")),
        Err(UrpError::NotAnInstallation { root }) if root == "URProgram"
    ));

    let mut p = read(EC);
    p.set_external_control_host(&s.host, s.port);
    let script = translate_with(&p, |node| {
        assert_eq!((node.host.as_str(), node.port), ("192.168.56.1", 50002));
        Ok(String::from("textmsg(1)"))
    });
    assert!(script.is_ok());
}

#[test]
fn variable_waypoints_and_nodes_between_waypoints() {
    let main = format!(
        r#"<Assignment><variable name="target"/>{target}</Assignment>
<Move motionType="MoveJ" speed="1.0" acceleration="1.4">
  <children>
    {w1}
    {between}
    <Waypoint type="Variable" name="target_wp"><variable reference="../../../../Assignment/variable"/></Waypoint>
  </children>
</Move>"#,
        target = expr("[0.3, -1.3, 1.2, -1.5, -1.57, 0.2]"),
        w1 = waypoint("Waypoint_1", Q1, r#"jointSpeed="0.5" blendRadius="0.02""#),
        between = script_line("textmsg(\"at 1\")"),
    );
    let p = read(&main);
    assert!(
        p.script
            .contains("movej([0.1, -1.5, 1.4, -1.5, -1.57, 0.2], a=1.4, v=0.5, r=0.02)"),
        "{}",
        p.script
    );
    assert!(
        p.script.contains("movej(target, a=1.4, v=1.0)"),
        "{}",
        p.script
    );
    let mut m = machine(&p.script);
    assert_eq!(texts(&run(&mut m, Duration::from_secs(30))), ["at 1"]);
    assert_eq!(m.state(), &State::Finished);
    assert!((m.joint_positions()[0] - 0.3).abs() < 1e-6);
}

#[test]
fn work_stays_linear_with_many_siblings_and_references() {
    // 20 000 calls of one sub program, each naming it by a reference to the last
    // sibling, and 10 000 External Control nodes: quadratic lookups would take minutes.
    let n = 20_000;
    let mut main = String::with_capacity(n * 80);
    for _ in 1..n {
        main.push_str(&format!(
            r#"<CallSubProgram><subprogram reference="../../CallSubProgram[{n}]/subprogram"/></CallSubProgram>"#
        ));
    }
    main.push_str(&format!(
        r#"<CallSubProgram><subprogram name="S"><children>{}</children></subprogram></CallSubProgram>"#,
        script_line("sync()")
    ));
    for _ in 0..10_000 {
        main.push_str(EC);
    }
    let xml = document("many", true, &main, "");
    let started = std::time::Instant::now();
    let p = read_urp(xml.as_bytes()).unwrap();
    assert_eq!(p.script.matches("  S()\n").count(), n);
    assert_eq!(p.external_control.len(), 10_000);
    assert_eq!(
        p.external_control[9_999].path,
        "URProgram/children/MainProgram/children/Contributed[10000]"
    );
    let script = translate_with(&p, |_| Ok(String::from("sync()"))).unwrap();
    assert_eq!(script.matches("sync()").count(), 10_001);
    assert!(
        started.elapsed() < Duration::from_secs(20),
        "{:?}",
        started.elapsed()
    );
}

#[test]
fn attributes_and_references_are_bounded() {
    use urscript_controller::urp::MAX_ATTRIBUTES;
    let attrs: String = (0..=MAX_ATTRIBUTES)
        .map(|i| format!(" a{i}=\"\""))
        .collect();
    let many = format!("<Halt{attrs}/>");
    assert!(
        matches!(read_urp(&urp(&many)), Err(UrpError::Xml { message, .. }) if message.contains("attributes"))
    );
    let long = "./".repeat(3000);
    let call = format!(r#"<CallSubProgram><subprogram reference="{long}"/></CallSubProgram>"#);
    assert!(
        matches!(read_urp(&urp(&call)), Err(UrpError::Invalid { message, .. }) if message.contains("longer"))
    );
}

#[test]
fn analog_waits_configurable_outputs_and_set_to_a_variable() {
    let main = format!(
        r#"<Set type="Expression"><variable name="level"/>{level}</Set>
<Wait type="AnalogInput"><pin referencedName="analog_in[1]"/><analogComparison>1</analogComparison><analogValue>2.5</analogValue></Wait>
<Set type="DigitalOutput"><pin referencedName="configurable_out[3]"/><digitalValue>1</digitalValue></Set>
<Set type="NoAction"/>
{report}"#,
        level = expr("get_standard_analog_in(1)"),
        report = script_line("textmsg(\"level \", level)"),
    );
    let p = read(&main);
    assert!(
        p.script
            .contains("global level = get_standard_analog_in(1)"),
        "{}",
        p.script
    );
    assert!(
        p.script
            .contains("while (not(get_standard_analog_in(1) > 2.5)):"),
        "{}",
        p.script
    );
    assert!(
        p.script.contains("set_configurable_digital_out(3, True)"),
        "{}",
        p.script
    );
    let mut m = machine(&p.script);
    assert!(run(&mut m, Duration::from_millis(100)).is_empty());
    assert_eq!(m.state(), &State::Running);
    m.world_mut().analog_in[1] = 3.0;
    assert_eq!(texts(&run(&mut m, Duration::from_millis(200))), ["level 0"]);
    assert!(
        m.arm().digital_out[11],
        "configurable outputs follow the 8 standard ones"
    );
    assert_eq!(m.state(), &State::Finished);

    let tcp = r#"<Set type="NoAction"><tcp referencedName="Gripper"/></Set>"#;
    assert!(matches!(
        read_urp(&urp(tcp)),
        Err(UrpError::Unsupported { .. })
    ));
    let pin = r#"<Set type="DigitalOutput"><pin referencedName="out3"/><digitalValue>1</digitalValue></Set>"#;
    assert!(
        matches!(read_urp(&urp(pin)), Err(UrpError::Invalid { message, .. }) if message.contains("out3"))
    );
}

/// Program trees of the translated nodes, with arbitrary texts where PolyScope keeps
/// texts (comments, messages, names).
fn arb_node() -> impl Strategy<Value = String> {
    let text = "[ -~\n\r\"'<>&\u{e9}\u{225f}]{0,20}";
    let escape = |s: String| {
        s.replace('&', "&amp;")
            .replace('"', "&quot;")
            .replace('<', "&lt;")
            .replace('>', "&gt;")
            .replace('\n', "&#10;")
            .replace('\r', "&#13;")
    };
    let leaf = prop_oneof![
        text.prop_map(move |t| format!("<Comment comment=\"{}\"/>", escape(t))),
        (text, any::<bool>(), 0..3u8).prop_map(move |(m, halt, kind)| format!(
            "<Popup type=\"{}\" haltProgram=\"{halt}\" message=\"{}\"/>",
            ["Message", "Warning", "Error"][kind as usize],
            escape(m)
        )),
        (0..10u32).prop_map(|ms| format!("<Wait type=\"Sleep\"><waitTime>0.{ms}</waitTime></Wait>")),
        Just("<Halt/>".to_string()),
        (0..8u8, any::<bool>()).prop_map(|(n, v)| format!(
            "<Set type=\"DigitalOutput\"><pin referencedName=\"digital_out[{n}]\"/><digitalValue>{}</digitalValue></Set>",
            u8::from(v)
        )),
        (0..100i32).prop_map(|v| format!("<Assignment><variable name=\"v\"/>{}</Assignment>", expr(&v.to_string()))),
        Just(script_line("textmsg(\"x\")")),
        (0..3u8).prop_map(|k| format!(
            "<Timer action=\"{}\"><variable name=\"t\"/></Timer>",
            ["Start", "Stop", "Reset"][k as usize]
        )),
        Just(r#"<SafeHome speed="1.0" acceleration="1.4"/>"#.to_string()),
        Just("<SuppressedNode><suppressedNode class=\"Halt\"/></SuppressedNode>".to_string()),
    ];
    leaf.prop_recursive(4, 24, 4, move |inner| {
        let kids = proptest::collection::vec(inner, 0..4).prop_map(|v| v.concat());
        prop_oneof![
            (kids.clone(), "[ -~]{0,10}").prop_map(|(k, name)| format!(
                "<Folder name=\"{}\"><children>{k}</children></Folder>",
                name.replace('&', "&amp;").replace('"', "&quot;").replace('<', "&lt;")
            )),
            kids.clone().prop_map(|k| format!("<Loop type=\"Forever\"><children>{k}</children></Loop>")),
            (kids.clone(), 0..4u32).prop_map(|(k, n)| format!(
                "<Loop type=\"Counting\" count=\"{n}\"><children>{k}</children></Loop>"
            )),
            (kids.clone(), kids.clone(), kids.clone()).prop_map(|(a, b, c)| format!(
                "<If type=\"If\">{}<children>{a}</children></If><If type=\"ElseIf\">{}<children>{b}</children></If><If type=\"Else\"><expression/><children>{c}</children></If>",
                expr("v \u{225f} 1"),
                expr("v > 2")
            )),
            kids.clone().prop_map(|k| format!(
                "<Loop type=\"While\" checkContinuously=\"true\">{}<children>{k}</children></Loop>",
                expr("v < 3")
            )),
            kids.clone().prop_map(|k| format!(
                "<If type=\"If\" checkContinuously=\"true\">{}<children>{k}</children></If>",
                expr("v < 3")
            )),
            kids.prop_map(|k| format!(
                "<CallSubProgram><subprogram name=\"Sub\"><children>{k}</children></subprogram></CallSubProgram>"
            )),
        ]
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// A tree of the translated nodes, whatever the texts in it, gives a program the
    /// interpreter accepts.
    #[test]
    fn translated_trees_always_parse(nodes in proptest::collection::vec(arb_node(), 0..5)) {
        // A second inline definition of `Sub` is refused (PolyScope saves a second call
        // as a reference to the first): that error is the one accepted.
        let main = format!("<Assignment><variable name=\"v\"/>{}</Assignment>{}", expr("0"), nodes.concat());
        match read_urp(&urp(&main)) {
            Ok(p) => {
                if let Err(e) = Program::parse(&p.script) {
                    panic!("{e:?}\n{}", p.script);
                }
            }
            Err(UrpError::Invalid { message, .. }) if message.contains("two sub programs") => {}
            Err(e) => panic!("{e}"),
        }
    }
}

#[test]
fn older_waypoints_with_a_stored_pose_and_movep_blends() {
    // Older files keep the joints and the pose as attributes of <position>.
    let main = r#"<Move motionType="MoveJ" speed="1.05" acceleration="1.4"><children>
  <Waypoint type="Fixed" name="Start"><position joints="0.1, -1.5, 1.4, -1.5, -1.57, 0.2"/></Waypoint>
</children></Move>
<Move motionType="MoveP" speed="0.1" acceleration="1.2" blendRadius="0.005"><children>
  <Waypoint type="Fixed" name="P1"><position joints="0, 0, 0, 0, 0, 0" pose="0.4, -0.1, 0.3, 0.0, 3.14, 0.0"/></Waypoint>
  <Waypoint type="Fixed" name="P2"><motionParameters blendRadius="0.0"/><position joints="0, 0, 0, 0, 0, 0" pose="0.4, -0.15, 0.3, 0.0, 3.14, 0.0"/></Waypoint>
</children></Move>"#;
    let p = read(main);
    assert!(
        p.script
            .contains("  # Start\n  movej([0.1, -1.5, 1.4, -1.5, -1.57, 0.2], a=1.4, v=1.05)\n"),
        "{}",
        p.script
    );
    assert!(
        p.script
            .contains("movep(p[0.4, -0.1, 0.3, 0.0, 3.14, 0.0], a=1.2, v=0.1, r=0.005)"),
        "{}",
        p.script
    );
    assert!(
        p.script
            .contains("movep(p[0.4, -0.15, 0.3, 0.0, 3.14, 0.0], a=1.2, v=0.1)\n"),
        "{}",
        p.script
    );

    let mut m = machine(&p.script);
    run(&mut m, Duration::from_secs(30));
    assert_eq!(m.state(), &State::Finished);
    let tcp = m.tcp_pose();
    for (got, want) in tcp.iter().zip([0.4, -0.15, 0.3]) {
        assert!((got - want).abs() < 1e-4, "tcp {tcp:?}");
    }

    let no_joints = r#"<Move motionType="MoveJ"><children><Waypoint type="Fixed"><position/></Waypoint></children></Move>"#;
    assert!(
        matches!(read_urp(&urp(no_joints)), Err(UrpError::Invalid { message, .. }) if message.contains("joint angles"))
    );
    let five = r#"<Move motionType="MoveJ"><children><Waypoint type="Fixed"><position><JointAngles angles="1, 2, 3, 4, 5"/></position></Waypoint></children></Move>"#;
    assert!(
        matches!(read_urp(&urp(five)), Err(UrpError::Invalid { message, .. }) if message.contains("6 values"))
    );
}

/// `.urp` files from elsewhere (not in the repository): with `URP_DIR` set, every `.urp`
/// in it translates, parses, and runs 5 s of virtual time without a runtime error (a
/// popup's wait, a halt, or the end of the program are fine). What the installation
/// would bring is supplied as found missing, and printed: a function no script defines
/// (a URCap's) is stubbed to do nothing, a Modbus signal is added (a register input on
/// 127.0.0.1) before the program's first line. Without `URP_DIR` this test checks
/// nothing.
#[test]
fn urp_files_from_urp_dir_translate_and_run() {
    let Some(dir) = std::env::var_os("URP_DIR") else {
        return;
    };
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "urp"))
        .collect();
    entries.sort();
    let mut failures = Vec::new();
    for path in entries {
        let bytes = std::fs::read(&path).unwrap();
        let program = match read_urp(&bytes) {
            Ok(p) => p,
            Err(e) => {
                failures.push(format!("{}: {e}", path.display()));
                continue;
            }
        };
        if let Err(e) = Program::parse(&program.script) {
            failures.push(format!("{}: {e:?}", path.display()));
            continue;
        }
        let (mut stubs, mut signals): (Vec<String>, Vec<String>) = (Vec::new(), Vec::new());
        for _ in 0..64 {
            let (head, body) = program.script.split_once('\n').unwrap();
            let mut script = format!("{head}\n");
            for s in &signals {
                script.push_str(&format!(
                    "  modbus_add_signal(\"127.0.0.1\", 255, 0, 2, \"{s}\", False)\n"
                ));
            }
            script.push_str(body);
            let mut config = Config::default();
            for s in &stubs {
                config = config.stub(s, urscript_interp::Stub::NoOp);
            }
            let mut m = Machine::new(Program::parse(&script).unwrap(), config);
            let messages = run(&mut m, Duration::from_secs(5));
            let unknown = m.unknown_functions();
            if !unknown.is_empty() {
                stubs.extend(unknown.into_iter().map(|(n, _)| n));
                continue;
            }
            if let State::Error(e) = m.state() {
                let missing = e
                    .message()
                    .split_once("no Modbus signal \"")
                    .and_then(|(_, rest)| rest.split_once('"'))
                    .map(|(name, _)| name.to_string());
                if let Some(name) = missing.filter(|n| !signals.contains(n)) {
                    signals.push(name);
                    continue;
                }
            }
            eprintln!(
                "{}: {:?} after {:?}; stubbed {stubs:?}; Modbus signals added {signals:?}; messages {:?}",
                path.display(),
                m.state(),
                m.now(),
                texts(&messages)
            );
            if matches!(m.state(), State::Error(_)) {
                failures.push(format!("{}: {:?}", path.display(), m.state()));
            }
            break;
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// A document with the given root children (the main program's among them).
fn root(name: &str, children: &str) -> Vec<u8> {
    gzip(
        format!(
            r#"<URProgram name="{name}" installation="default" createdIn="5.11.0"><children>{children}</children></URProgram>"#
        )
        .as_bytes(),
    )
}

#[test]
fn threads_are_defined_looped_and_started_after_before_start() {
    let doc = root(
        "threads",
        &format!(
            r#"<InitVariablesNode/>
<SpecialSequence type="BeforeStart"><children>
  <Assignment valueSource="Expression"><variable name="n"/>{zero}</Assignment>
</children></SpecialSequence>
<MainProgram runOnlyOnce="true"><children>
  <Wait type="Sleep"><waitTime>0.1</waitTime></Wait>
  {report}
</children></MainProgram>
<Thread name="Thread_1" runOnlyOnce="false" trackProgramExecution="false"><children>
  <Assignment valueSource="Expression"><variable reference="../../../../SpecialSequence/children/Assignment/variable"/>{incr}</Assignment>
  <Wait type="Sleep"><waitTime>0.02</waitTime></Wait>
</children></Thread>
<Thread name="Thread_2" runOnlyOnce="true"><children>{once}</children></Thread>"#,
            zero = expr("0"),
            incr = expr("n + 1"),
            report = script_line("textmsg(\"n = \", n)"),
            once = script_line("textmsg(\"once\")"),
        ),
    );
    let p = read_urp(&doc).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        p.script,
        "def threads():
  global n = 0
  thread Thread_1():
    while (True):
      global n = n + 1
      sleep(0.02)
    end
  end
  thread Thread_2():
    textmsg(\"once\")
  end
  threadId_Thread_1 = run Thread_1()
  threadId_Thread_2 = run Thread_2()
  sleep(0.1)
  textmsg(\"n = \", n)
end
"
    );
    let mut m = machine(&p.script);
    let shown = run(&mut m, Duration::from_secs(1));
    // Thread_1 adds 1 at 0, 20, 40, 60 and 80 ms (and at 100 ms, if it runs first).
    let shown = texts(&shown);
    assert_eq!(shown[0], "once", "{shown:?}");
    assert!(matches!(shown[1], "n = 5" | "n = 6"), "{shown:?}");
    assert_eq!(m.state(), &State::Finished);
}

#[test]
fn hostile_threads_are_errors() {
    let main = r#"<MainProgram runOnlyOnce="true"><children><Halt/></children></MainProgram>"#;
    let cases = [
        (
            r#"<Thread name="T" runOnlyOnce="maybe"><children><Halt/></children></Thread>"#,
            "runOnlyOnce",
        ),
        (
            r#"<Thread name="T"><children><Halt/></children></Thread><Thread name="T"/>"#,
            "two threads",
        ),
        (r#"<Thread name=" "/>"#, "name is empty"),
    ];
    for (threads, why) in cases {
        match read_urp(&root("t", &format!("{main}{threads}"))) {
            Err(UrpError::Invalid { path, message }) => {
                assert!(path.contains("Thread"), "{path}");
                assert!(message.contains(why), "{message}");
            }
            other => panic!("{threads}: {other:?}"),
        }
    }
    // A thread named as a definition the translation writes, or as a sub program.
    let timer = r#"<MainProgram runOnlyOnce="true"><children><Timer action="Start"><variable name="t"/></Timer></children></MainProgram>"#;
    let clash = read_urp(&root(
        "t",
        &format!("{timer}<Thread name=\"Timer_Thread\"/>"),
    ))
    .unwrap_err();
    assert_eq!(
        clash.to_string(),
        "URProgram/children/Thread: the thread Timer_Thread has the name of another definition"
    );
    let sub = r#"<Thread name="S"><children><CallSubProgram><subprogram name="S"/></CallSubProgram></children></Thread>"#;
    let clash = read_urp(&root("t", &format!("{main}{sub}"))).unwrap_err();
    assert!(
        clash.to_string().contains("the thread S has the name"),
        "{clash}"
    );
    let watched = format!(
        r#"<MainProgram runOnlyOnce="true"><children><Loop type="While" checkContinuously="true">{}<children/></Loop>
<CallSubProgram><subprogram name="Thread_while_1"/></CallSubProgram></children></MainProgram>"#,
        expr("True")
    );
    let clash = read_urp(&root("t", &watched)).unwrap_err();
    assert!(
        clash
            .to_string()
            .contains("the sub program Thread_while_1 has the name of a thread"),
        "{clash}"
    );
    // A thread's nodes are checked as any others.
    assert!(matches!(
        read_urp(&root("t", &format!("{main}<Thread name=\"T\"><children><Gripper/></children></Thread>"))),
        Err(UrpError::UnknownNode { name, path }) if name == "Gripper" && path == "URProgram/children/Thread/children/Gripper"
    ));
    // Many threads: each defined and started, the work linear.
    let many: String = (0..2000)
        .map(|k| {
            format!(
                "<Thread name=\"T{k}\" runOnlyOnce=\"true\"><children><Halt/></children></Thread>"
            )
        })
        .collect();
    let p = read_urp(&root("t", &format!("{main}{many}"))).unwrap();
    assert_eq!(p.script.matches(" = run T").count(), 2000);
    Program::parse(&p.script).unwrap();
}

#[test]
fn timers_count_while_started_as_polyscope_counts_them() {
    let doc = root(
        "timers",
        &format!(
            r#"<SpecialSequence type="BeforeStart"><children>
  <Timer action="Start"><variable name="timer_1" prefersPersistentValue="false"/></Timer>
</children></SpecialSequence>
<MainProgram runOnlyOnce="true"><children>
  <Wait type="Sleep"><waitTime>0.5</waitTime></Wait>
  <Timer action="Stop"><variable reference="../../../../SpecialSequence/children/Timer/variable"/></Timer>
  <Wait type="Sleep"><waitTime>0.2</waitTime></Wait>
  {report}
  <Timer action="Reset"><variable reference="../../../../SpecialSequence/children/Timer/variable"/></Timer>
  {report}
</children></MainProgram>"#,
            report = script_line("textmsg(timer_1)"),
        ),
    );
    let p = read_urp(&doc).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        p.script,
        "def timers():
  global timer_1 = 0
  global timer_1_is_counting = False
  thread Timer_Thread():
    while (True):
      if (timer_1_is_counting):
        timer_1 = timer_1 + get_steptime()
      end
      sync()
    end
  end
  run Timer_Thread()
  timer_1_is_counting = True
  sleep(0.5)
  timer_1_is_counting = False
  sleep(0.2)
  textmsg(timer_1)
  timer_1 = 0
  textmsg(timer_1)
end
"
    );
    let mut m = machine(&p.script);
    let shown = run(&mut m, Duration::from_secs(1));
    let shown = texts(&shown);
    let counted: f64 = shown[0].parse().unwrap_or_else(|_| panic!("{shown:?}"));
    assert!((counted - 0.5).abs() <= 0.005, "{shown:?}");
    assert_eq!(shown[1], "0");

    for (timer, bad) in [
        (
            r#"<Timer action="Pause"><variable name="t"/></Timer>"#,
            "timer action Pause",
        ),
        (r#"<Timer><variable name="t"/></Timer>"#, "no action"),
        (r#"<Timer action="Start"/>"#, "no <variable>"),
        (
            r#"<Timer action="Start"><variable name="1t"/></Timer>"#,
            "not a variable name",
        ),
    ] {
        let err = read_urp(&urp(timer)).unwrap_err();
        assert!(err.to_string().contains(bad), "{timer}: {err}");
        assert!(
            err.to_string().contains("MainProgram/children/Timer"),
            "{err}"
        );
    }
}

#[test]
fn home_moves_to_the_default_home_position() {
    let main = r#"<SafeHome positionOptionType="SPEED_AND_ACCELERATION" speed="1.0471975511965976" acceleration="1.3962634015954636" nextMotionTime="2.0"/>
<Move motionType="MoveJ" speed="1.0" acceleration="1.4"><children>
  <SafeHome speed="0.5" acceleration="0.8"/>
</children></Move>"#;
    let p = read(main);
    assert_eq!(
        p.script,
        "def test():
  # Home
  movej([0.0, -1.5707963267948966, 0.0, -1.5707963267948966, 0.0, 0.0], a=1.3962634015954636, v=1.0471975511965976)
  # Home
  movej([0.0, -1.5707963267948966, 0.0, -1.5707963267948966, 0.0, 0.0], a=0.8, v=0.5)
end
"
    );
    let mut m = machine(&p.script);
    run(&mut m, Duration::from_secs(20));
    assert_eq!(m.state(), &State::Finished);
    for (q, home) in m
        .joint_positions()
        .iter()
        .zip(urscript_controller::urp::DEFAULT_HOME_JOINTS)
    {
        assert!((q - home).abs() < 1e-6, "{:?}", m.joint_positions());
    }
    for (node, bad) in [
        (r#"<SafeHome speed="-1"/>"#, "not positive"),
        (r#"<SafeHome acceleration="fast"/>"#, "not a number"),
        (r#"<SafeHome speed="1e999"/>"#, "not a number"),
        (
            r#"<SafeHome positionOptionType="TIME" speed="1"/>"#,
            "not supported",
        ),
    ] {
        let err = read_urp(&urp(node)).unwrap_err();
        assert!(err.to_string().contains(bad), "{node}: {err}");
        assert!(
            err.to_string()
                .starts_with("URProgram/children/MainProgram/children/SafeHome"),
            "{err}"
        );
    }
}

#[test]
fn operator_assignments_io_tokens_initial_variables_and_suppressed_nodes() {
    let doc = root(
        "misc",
        &format!(
            r#"<InitVariablesNode><variables>
  <variable name="ip">{ip}</variable>
  <variable name="count">{zero}</variable>
</variables></InitVariablesNode>
<MainProgram runOnlyOnce="true"><children>
  <Assignment valueSource="Operator" message="Mirror mode?" valueType="Boolean"><variable name="mirror"/></Assignment>
  <Assignment valueSource="Operator" message="How many?" valueType="Integer"><variable name="many"/></Assignment>
  <SuppressedNode><suppressedNode class="Halt"/></SuppressedNode>
  <Assignment valueSource="Expression"><variable name="x"/><expression>
    <ExpressionIO><pin referencedName="base"/></ExpressionIO><ExpressionChar character="+"/>
    <ExpressionIO><pin referencedName="digital_in[3]"/></ExpressionIO>
  </expression></Assignment>
</children></MainProgram>"#,
            ip = expr("\"10.0.0.2\""),
            zero = expr("0"),
        ),
    );
    let p = read_urp(&doc).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        p.script,
        "def misc():
  global ip = \"10.0.0.2\"
  global count = 0
  global mirror = request_boolean_from_primary_client(\"Mirror mode?\")
  global many = request_integer_from_primary_client(\"How many?\")
  global x = modbus_get_signal_status(\"base\", False)+get_standard_digital_in(3)
end
"
    );
    Program::parse(&p.script).unwrap();
    for (node, bad) in [
        (
            r#"<Assignment valueSource="Operator" message="m"><variable name="v"/></Assignment>"#,
            "without valueType",
        ),
        (
            r#"<Assignment valueSource="Operator" valueType="Pose"><variable name="v"/></Assignment>"#,
            "of type Pose",
        ),
        (
            r#"<Assignment><variable name="v"/><expression><ExpressionIO/></expression></Assignment>"#,
            "no <pin>",
        ),
        (
            r#"<Assignment><variable name="v"/><expression><ExpressionIO><pin referencedName="a&quot;b"/></ExpressionIO></expression></Assignment>"#,
            "not a signal name",
        ),
        (
            r#"<Assignment><variable name="v"/><expression><ExpressionIO><pin referencedName="digital_in[x]"/></ExpressionIO></expression></Assignment>"#,
            "not of the form",
        ),
    ] {
        let err = read_urp(&urp(node)).unwrap_err();
        assert!(err.to_string().contains(bad), "{node}: {err}");
        assert!(
            err.to_string()
                .starts_with("URProgram/children/MainProgram/children/Assignment"),
            "{err}"
        );
    }
    let bad_init = root(
        "b",
        r#"<InitVariablesNode><variables><variable name="v"/></variables></InitVariablesNode><MainProgram/>"#,
    );
    assert!(read_urp(&bad_init)
        .unwrap_err()
        .to_string()
        .contains("no <expression>"));
}

#[test]
fn while_loops_checked_continuously_stop_their_thread_when_false() {
    let main = format!(
        r#"<Assignment><variable name="i"/>{zero}</Assignment>
<Loop type="While" checkContinuously="true">{cond}<children>
  <Assignment><variable name="i"/>{incr}</Assignment>
  <Wait type="Sleep"><waitTime>0.01</waitTime></Wait>
  {never}
</children></Loop>
{report}"#,
        zero = expr("0"),
        cond = expr("i < 5"),
        incr = expr("i + 1"),
        never = script_line("textmsg(\"late\")"),
        report = script_line("textmsg(\"i = \", i)"),
    );
    let p = read(&main);
    assert_eq!(
        p.script,
        "def test():
  thread Thread_while_1():
    while (True):
      global i = i + 1
      sleep(0.01)
      textmsg(\"late\")
    end
  end
  global i = 0
  if (i < 5):
    global thread_handler_1 = run Thread_while_1()
    while (i < 5):
      sync()
    end
    kill thread_handler_1
  end
  textmsg(\"i = \", i)
end
"
    );
    let mut m = machine(&p.script);
    let shown = run(&mut m, Duration::from_secs(1));
    // The fifth increment makes the condition false: the thread is killed in its
    // sleep, before its message.
    assert_eq!(texts(&shown), ["late", "late", "late", "late", "i = 5"]);
    assert_eq!(m.state(), &State::Finished);
    // Many of them, each with an External Control node: one thread each, linear work.
    let many: String = (0..3000)
        .map(|_| {
            format!(
                r#"<Loop type="While" checkContinuously="true">{}<children>{EC}</children></Loop>"#,
                expr("i < 5")
            )
        })
        .collect();
    let started = std::time::Instant::now();
    let p = read_urp(&urp(&format!(
        "<Assignment><variable name=\"i\"/>{}</Assignment>{many}",
        expr("0")
    )))
    .unwrap();
    assert_eq!(p.external_control.len(), 3000);
    let script = translate_with(&p, |_| Ok(String::from("sync()"))).unwrap();
    assert_eq!(script.matches("thread Thread_while_").count(), 3000);
    assert!(started.elapsed() < Duration::from_secs(10));
    let forever =
        r#"<Loop type="Forever" checkContinuously="true"><children><Halt/></children></Loop>"#;
    assert!(matches!(
        read_urp(&urp(forever)),
        Err(UrpError::Unsupported { .. })
    ));
}

#[test]
fn ifs_checked_continuously_stop_their_thread_when_false() {
    let main = format!(
        r#"<Assignment><variable name="go"/>{yes}</Assignment>
<Assignment><variable name="steps"/>{zero}</Assignment>
<If type="If" checkContinuously="true">{cond}<children>
  <Loop type="Counting" count="10"><children>
    <Assignment><variable name="steps"/>{incr}</Assignment>
    <If type="If">{third}<children><Assignment><variable name="go"/>{no}</Assignment></children></If>
    <Wait type="Sleep"><waitTime>0.01</waitTime></Wait>
  </children></Loop>
</children></If>
{report}"#,
        yes = expr("True"),
        no = expr("False"),
        zero = expr("0"),
        cond = expr("go"),
        incr = expr("steps + 1"),
        third = expr("steps \u{225f} 3"),
        report = script_line("textmsg(\"steps = \", steps)"),
    );
    let p = read(&main);
    assert_eq!(
        p.script,
        "def test():
  thread Thread_if_1():
    Loop_1 = 0
    while (Loop_1 < 10):
      global steps = steps + 1
      if (steps == 3):
        global go = False
      end
      sleep(0.01)
      Loop_1 = Loop_1 + 1
    end
    thread_flag_1 = 1
  end
  global go = True
  global steps = 0
  global thread_flag_1 = 0
  if (go):
    global thread_handler_1 = run Thread_if_1()
    while (thread_flag_1 == 0):
      if not(go):
        kill thread_handler_1
        thread_flag_1 = 2
      else:
        sync()
      end
    end
  else:
    thread_flag_1 = 2
  end
  textmsg(\"steps = \", steps)
end
"
    );
    let mut m = machine(&p.script);
    let shown = run(&mut m, Duration::from_secs(1));
    assert_eq!(texts(&shown), ["steps = 3"]);
    assert_eq!(m.state(), &State::Finished);
}

#[test]
fn a_feature_in_an_expression_is_the_features_pose_variable() {
    // PolyScope writes a feature used as a value as an `<ExpressionGeomFeature>` token;
    // the script names the feature's pose variable, which the installation defines (here
    // a preamble does, as a test would with `--preamble`).
    let p = read(
        r#"<Assignment valueSource="Expression"><variable name="above"/><expression>
  <ExpressionChar character="p"/><ExpressionChar character="o"/><ExpressionChar character="s"/><ExpressionChar character="e"/><ExpressionChar character="_"/><ExpressionChar character="t"/><ExpressionChar character="r"/><ExpressionChar character="a"/><ExpressionChar character="n"/><ExpressionChar character="s"/><ExpressionChar character="("/>
  <ExpressionGeomFeature><feature referencedName="Plane_1"/></ExpressionGeomFeature>
  <ExpressionChar character=","/><ExpressionChar character=" "/><ExpressionChar character="p"/><ExpressionChar character="["/><ExpressionChar character="0"/><ExpressionChar character=","/><ExpressionChar character="0"/><ExpressionChar character=","/><ExpressionChar character="0"/><ExpressionChar character="."/><ExpressionChar character="1"/><ExpressionChar character=","/><ExpressionChar character="0"/><ExpressionChar character=","/><ExpressionChar character="0"/><ExpressionChar character=","/><ExpressionChar character="0"/><ExpressionChar character="]"/><ExpressionChar character=")"/>
</expression></Assignment>"#,
    );
    assert!(
        p.script
            .contains("global above = pose_trans(Plane_1, p[0,0,0.1,0,0,0])"),
        "{}",
        p.script
    );
    let mut preamble = urscript_interp::Preamble::default();
    preamble
        .add("global Plane_1 = p[0.4, 0, 0.2, 0, 0, 0]\n")
        .unwrap();
    let program = Program::parse_with_preamble(&preamble, &p.script).unwrap();
    let mut m = Machine::new(program, Config::default());
    m.run_until(Duration::from_millis(10));
    assert_eq!(m.state(), &State::Finished);
    let Some(urscript_interp::Value::Pose(above)) = m.global("above") else {
        panic!("{:?}", m.global("above"))
    };
    assert!((above[2] - 0.3).abs() < 1e-12, "{above:?}");
    // A feature token that names nothing is refused, with where it is.
    let err = read_urp(&urp(
        r#"<Assignment><variable name="v"/><expression><ExpressionGeomFeature/></expression></Assignment>"#,
    ))
    .unwrap_err();
    assert!(err.to_string().contains("names no feature"), "{err}");
}
