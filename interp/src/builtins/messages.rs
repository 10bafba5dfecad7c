//! Messages to the operator and the log: `textmsg`, `varmsg`, `popup`. Each becomes an
//! [`Event::Message`]; a popup never blocks (the virtual
//! operator closes it at once).

use super::{builtin, Args, Builtin, Domain, Out};
use crate::error::Fault;
use crate::event::{Event, Message, MessageKind};
use crate::runtime::Runtime;
use crate::value::Value;

const D: Domain = Domain::Messages;

pub(super) const TABLE: &[Builtin] = &[
    builtin!(
        textmsg(s1: &Value, s2: &Value = Str("")) => textmsg,
        "Writes s1 and s2 (as to_str writes them) to the log.",
    ),
    builtin!(
        varmsg(name: &Value, value: &Value) => varmsg,
        "Writes `name = value` to the log.",
    ),
    builtin!(
        popup(
            s: &Value,
            title: &Value = Str("Popup"),
            warning: bool = Bool(false),
            error: bool = Bool(false),
            blocking: bool = Bool(false),
        ) => popup,
        "Shows a popup (a message event; it never blocks here).",
    ),
];

/// The message event: `args` are the call's arguments, of which the first
/// `Args::positional` were given by position (the event keeps those).
fn show<const N: usize>(
    c: &mut Runtime,
    a: &Args,
    kind: MessageKind,
    text: String,
    args: [&Value; N],
) -> Out {
    let given = a.positional.min(args.len());
    c.events.push_back(Event::Message(Message {
        line: a.line,
        kind,
        text,
        args: args.into_iter().take(given).cloned().collect(),
    }));
    Out::Value(Value::None)
}

fn textmsg(c: &mut Runtime, a: &mut Args, s1: &Value, s2: &Value) -> Result<Out, Fault> {
    let text = format!("{}{}", s1.to_str(), s2.to_str());
    Ok(show(c, a, MessageKind::Textmsg, text, [s1, s2]))
}

fn varmsg(c: &mut Runtime, a: &mut Args, name: &Value, value: &Value) -> Result<Out, Fault> {
    let text = format!("{} = {}", name.to_str(), value.to_str());
    Ok(show(c, a, MessageKind::Varmsg, text, [name, value]))
}

fn popup(
    c: &mut Runtime,
    a: &mut Args,
    s: &Value,
    title: &Value,
    warning: bool,
    error: bool,
    blocking: bool,
) -> Result<Out, Fault> {
    let kind = MessageKind::Popup {
        title: title.to_str(),
        warning,
        error,
        blocking,
    };
    let flags = [warning, error, blocking].map(Value::Bool);
    let text = s.to_str();
    let [w, e, b] = &flags;
    Ok(show(c, a, kind, text, [s, title, w, e, b]))
}
