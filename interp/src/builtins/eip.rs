//! The e-Series 5.x manual's "Flexible Ethernet/IP Adapter" functions (PolyScope 5.16
//! and later): `eip_reader_factory` and `eip_writer_factory` return handles whose
//! methods (`define_*`, `read`, `write`, `clear`, the watchdog, `close`) act on the
//! virtual adapter; see [`crate::eip`] for the model, its choices and bounds. The
//! adapter's configuration service (`add_configuration`, `is_instance_connected`) is
//! reached as on the robot, through `rpc_factory("xmlrpc", "http://127.0.0.1:40000/RPC2")`.

use super::{builtin, Builtin, Domain, Out};
use crate::error::Fault;
use crate::runtime::Runtime;

const D: Domain = Domain::Io;

pub(super) const TABLE: &[Builtin] = &[
    builtin!(
        eip_reader_factory(instance_name: &[u8], data_size: i32)
            => |c, _, name, size| open(c, false, name, size),
        "Opens a read-only handle on the PLC→Robot EtherNet/IP instance `instance_name` (an id as a string) of `data_size` bytes.",
    ),
    builtin!(
        eip_writer_factory(instance_name: &[u8], data_size: i32)
            => |c, _, name, size| open(c, true, name, size),
        "Opens a write-only handle on the Robot→PLC EtherNet/IP instance `instance_name` (an id as a string) of `data_size` bytes.",
    ),
];

/// A handle on instance `name` of `size` bytes: a writer's (Robot→PLC) or a reader's.
fn open(c: &mut Runtime, writer: bool, name: &[u8], size: i32) -> Result<Out, Fault> {
    let Runtime { eip, arm, .. } = c;
    eip.open(&mut arm.eip, writer, name, size).map(Out::Value)
}
