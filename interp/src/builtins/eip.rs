//! The e-Series 5.x manual's "Flexible Ethernet/IP Adapter" functions (PolyScope 5.16
//! and later): `eip_reader_factory` and `eip_writer_factory` return handles whose
//! methods (`define_*`, `read`, `write`, `clear`, the watchdog, `close`) act on the
//! virtual adapter; see [`crate::eip`] for the model, its choices and bounds. The
//! adapter's configuration service (`add_configuration`, `is_instance_connected`) is
//! reached as on the robot, through `rpc_factory("xmlrpc", "http://127.0.0.1:40000/RPC2")`.

use super::{req, Args, Builtin, Domain, Out};
use crate::error::Fault;
use crate::runtime::Runtime;

const PARAMS: &[super::Param] = &[req("instance_name"), req("data_size")];

pub(super) const TABLE: &[Builtin] = &[
    Builtin::new(
        "eip_reader_factory",
        Domain::Io,
        PARAMS,
        "Opens a read-only handle on the PLC→Robot EtherNet/IP instance `instance_name` (an id as a string) of `data_size` bytes.",
        reader,
    ),
    Builtin::new(
        "eip_writer_factory",
        Domain::Io,
        PARAMS,
        "Opens a write-only handle on the Robot→PLC EtherNet/IP instance `instance_name` (an id as a string) of `data_size` bytes.",
        writer,
    ),
];

fn open(c: &mut Runtime, a: &Args, writer: bool) -> Result<Out, Fault> {
    let name = a.bytes(0)?.to_vec();
    let size = a.int(1)?;
    let Runtime { eip, arm, .. } = c;
    eip.open(&mut arm.eip, writer, &name, size).map(Out::Value)
}

fn reader(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    open(c, a, false)
}

fn writer(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    open(c, a, true)
}
