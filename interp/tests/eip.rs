//! The Flexible EtherNet/IP Adapter (the manual's chapter 20) on the virtual controller:
//! a machine-tending program in the style of UR's examples (written for this test)
//! configures its assemblies through the adapter's XML-RPC service on port 40000, opens
//! handles, defines their layouts, waits for the PLC and answers it; the watchdog.
use std::time::Duration;

use urscript_interp::{Config, Effect, Event, Machine, Program, RuntimeErrorKind, State, Value};

const CELL: &str = r#"def cell():
  global cfg = rpc_factory("xmlrpc", "http://127.0.0.1:40000/RPC2")
  global ok = cfg.add_configuration(102, 16, 122, 12)
  cfg.closeXMLRPCClientConnection()
  sleep(1)
  global plc = eip_reader_factory("122", 12)
  plc.define_bit(0, 0, "alive")
  plc.define_bit(0, 3, "door_closed")
  plc.define_uint16(2, "job")
  plc.define_float32(4, "offset_mm")
  plc.define_string(8, 4, "tag")
  global robot = eip_writer_factory("102", 16)
  robot.define_bit(0, 0, "ready")
  robot.define_int16(2, "count")
  robot.define_uint8_array(4, 4, "slots")
  robot.define_string(8, 8, "state")
  robot.write(struct(ready=True, state="idle"))
  while not plc.read("door_closed"):
    sync()
  end
  req = plc.read(["job", "offset_mm", "tag"])
  textmsg("job ", req.job)
  textmsg("offset ", req.offset_mm)
  textmsg("tag ", req.tag)
  s = struct(ready=False, count=0, slots=[0], state="")
  s.count = req.job * 2
  s.slots = [1, 2, 3]
  s.state = "busy"
  robot.write(s)
  global connected = cfg.is_instance_connected(122)
  plc.close()
end
"#;

fn messages(m: &mut Machine) -> Vec<String> {
    std::iter::from_fn(|| m.poll_event())
        .filter_map(|e| match e {
            Event::Message(msg) => Some(msg.text),
            _ => None,
        })
        .collect()
}

#[test]
fn a_machine_tending_cell_talks_to_its_plc() {
    let mut m = Machine::new(Program::parse(CELL).unwrap(), Config::default());
    m.world_mut().eip_connected = true;
    m.run_until(Duration::from_millis(1500));
    assert_eq!(m.state(), &State::Running, "waits for the door");
    assert_eq!(m.global("ok"), Some(&Value::Bool(true)));
    // The robot's first write: ready (bit 0 of byte 0) and "idle".
    let arm = m.arm();
    let data = arm.eip_to_plc(102).unwrap();
    assert_eq!(data.len(), 16);
    assert_eq!(data[0], 1);
    assert_eq!(&data[8..13], b"idle\0");
    // The PLC closes the door and sends job 0x0103, 2.5 mm and "AB".
    let mut frame = vec![0b1001, 0, 0x03, 0x01];
    frame.extend_from_slice(&2.5f32.to_le_bytes());
    frame.extend_from_slice(b"AB\0\0");
    m.world_mut().eip_from_plc.insert(122, frame);
    m.run_until(Duration::from_millis(1600));
    assert_eq!(m.state(), &State::Finished, "{:?}", m.state());
    assert_eq!(messages(&mut m), ["job 259", "offset 2.5", "tag AB"]);
    let arm = m.into_arm();
    let data = arm.eip_to_plc(102).unwrap();
    // ready cleared, count 518 little-endian, slots 1 2 3 0, "busy".
    assert_eq!(&data[..8], &[0, 0, 0x06, 0x02, 1, 2, 3, 0]);
    assert_eq!(&data[8..16], b"busy\0\0\0\0");
}

#[test]
fn is_instance_connected_follows_the_scanner() {
    let mut m = Machine::new(Program::parse(CELL).unwrap(), Config::default());
    m.world_mut().eip_from_plc.insert(122, vec![0b1000]);
    m.run_until(Duration::from_secs(2));
    assert_eq!(m.state(), &State::Finished, "{:?}", m.state());
    assert_eq!(m.global("connected"), Some(&Value::Bool(false)));
}

fn watchdog(action: i32, connected: bool) -> Machine {
    let src = format!(
        "r = eip_reader_factory(\"111\", 4)\nr.set_watchdog(2.5, {action})\nsleep(1)\ntextmsg(\"after\")\n"
    );
    let mut m = Machine::new(Program::parse(&src).unwrap(), Config::default());
    m.world_mut().eip_connected = connected;
    m
}

#[test]
fn a_watchdog_without_a_scanner_stops_the_program() {
    let mut m = watchdog(2, false);
    m.run_until(Duration::from_millis(398));
    assert_eq!(m.state(), &State::Running);
    m.run_until(Duration::from_millis(402));
    let State::Error(e) = m.state() else {
        panic!("{:?}", m.state())
    };
    assert!(e.message().contains("watchdog"), "{e}");
    assert!(e.message().contains("instance 111"), "{e}");
    assert!(m.effects().contains(&Effect::ProtectiveStop));
}

#[test]
fn a_pausing_watchdog_asks_for_a_protective_stop_and_a_fed_one_stays_quiet() {
    let mut m = watchdog(1, false);
    m.run_until(Duration::from_millis(500));
    assert!(m.effects().contains(&Effect::ProtectiveStop));
    let mut m = watchdog(2, true);
    m.run_until(Duration::from_secs(2));
    assert_eq!(m.state(), &State::Finished);
    assert!(!m.effects().contains(&Effect::ProtectiveStop));
    let mut m = watchdog(0, false);
    m.run_until(Duration::from_secs(2));
    assert_eq!(m.state(), &State::Finished);
}

#[test]
fn misuse_is_a_runtime_error_naming_the_method() {
    for (src, want) in [
        ("r = eip_reader_factory(111, 4)\n", "needs a string"),
        ("r = eip_reader_factory(\"x\", 4)\n", "instance id"),
        ("r = eip_reader_factory(\"1\", 0)\n", "data_size"),
        (
            "r = eip_reader_factory(\"1\", 4)\nr.write(struct(a=1))\n",
            "read only",
        ),
        (
            "w = eip_writer_factory(\"1\", 4)\nw.read(\"a\")\n",
            "write only",
        ),
        (
            "w = eip_writer_factory(\"1\", 4)\nw.define_int32(1, \"a\")\n",
            "past the instance",
        ),
        (
            "w = eip_writer_factory(\"1\", 4)\nw.define_uint8(0, \"a\")\nw.write(struct(a=256))\n",
            "outside the range",
        ),
        (
            "w = eip_writer_factory(\"1\", 4)\nw.close()\nw.clear()\n",
            "closed",
        ),
        (
            "w = eip_writer_factory(\"1\", 4)\nw.fly()\n",
            "no method `.fly`",
        ),
        (
            "w = eip_writer_factory(\"1\", 4)\nw.set_watchdog(1, 1)\n",
            "reader handle",
        ),
        (
            "r = eip_reader_factory(\"1\", 4)\nr.stop_watchdog()\n",
            "no watchdog",
        ),
        (
            "c = rpc_factory(\"xmlrpc\", \"http://127.0.0.1:40000/RPC2\")\nc.reboot()\n",
            "no method `reboot`",
        ),
    ] {
        let mut m = Machine::new(Program::parse(src).unwrap(), Config::default());
        m.run_until(Duration::from_millis(10));
        let State::Error(e) = m.state() else {
            panic!("{src}: {:?}", m.state())
        };
        assert!(e.message().contains(want), "{src}: {e}");
        assert_ne!(e.kind(), RuntimeErrorKind::Internal);
    }
}

#[test]
fn handles_are_bounded() {
    let src = "i = 0\nwhile i < 100:\n  h = eip_reader_factory(\"5\", 4)\n  i = i + 1\nend\n";
    let mut m = Machine::new(Program::parse(src).unwrap(), Config::default());
    m.run_until(Duration::from_millis(10));
    let State::Error(e) = m.state() else {
        panic!("{:?}", m.state())
    };
    assert_eq!(e.kind(), RuntimeErrorKind::Limit);
    assert_eq!(m.global("i"), Some(&Value::Int(64)));
}

#[test]
fn the_world_takes_the_plcs_data_from_a_setting() {
    let mut w = urscript_interp::World::default();
    w.set("eip_from_plc[122]=[9, 0, 255]").unwrap();
    w.set("eip_connected=True").unwrap();
    assert_eq!(w.eip_from_plc[&122], vec![9, 0, 255]);
    assert!(w.eip_connected);
    assert!(w.set("eip_from_plc[122]=[256]").is_err());
    assert!(w.set("eip_from_plc=[1]").is_err());
}
