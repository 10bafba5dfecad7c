//! `rpc_factory` of the e-Series 5.x manual's Interfaces chapter: a handle whose methods
//! are XML-RPC calls (`camera = rpc_factory("xmlrpc", "http://10.0.0.5:8000/RPC2")`, then
//! `target = camera.getTarget()`). Making the handle sends nothing; each
//! `handle.name(args...)` connects, sends one HTTP POST and waits for the reply (see
//! the crate docs' "Bounds" and the package README for the types, errors and bounds).

use super::{builtin, Args, Builtin, Domain, Out};
use crate::error::Fault;
use crate::runtime::Runtime;
use crate::value::Value;

const D: Domain = Domain::Sockets;

pub(super) const TABLE: &[Builtin] = &[builtin!(
    rpc_factory(r#type: String, url: String) => rpc_factory,
    "Returns a handle for remote procedure calls to an XML-RPC server (type \"xmlrpc\", url http://host[:port]/path); `handle.name(args)` calls `name` on it.",
)];

fn rpc_factory(_: &mut Runtime, _: &mut Args, kind: String, url: String) -> Result<Out, Fault> {
    if kind != "xmlrpc" {
        return Err(format!("`rpc_factory`: type must be \"xmlrpc\", got \"{kind}\"").into());
    }
    crate::rpc::parse_url(&url).map_err(|e| format!("`rpc_factory`: {e}"))?;
    Ok(Out::Value(Value::Rpc(url)))
}
