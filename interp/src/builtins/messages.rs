//! Messages to the operator and the log: `textmsg`, `varmsg`, `popup`. Each becomes an
//! [`Event::Message`]; a popup never blocks (the virtual
//! operator closes it at once).

use super::{opt, req, Args, Builtin, Default, Domain, Out};
use crate::error::Fault;
use crate::event::{Event, Message, MessageKind};
use crate::runtime::Runtime;
use crate::value::Value;

const D: Domain = Domain::Messages;

pub(super) const TABLE: &[Builtin] = &[
    Builtin::new(
        "textmsg",
        D,
        &[req("s1"), opt("s2", Default::Str(""))],
        "Writes s1 and s2 (as to_str writes them) to the log.",
        textmsg,
    ),
    Builtin::new(
        "varmsg",
        D,
        &[req("name"), req("value")],
        "Writes `name = value` to the log.",
        varmsg,
    ),
    Builtin::new(
        "popup",
        D,
        &[
            req("s"),
            opt("title", Default::Str("Popup")),
            opt("warning", Default::Bool(false)),
            opt("error", Default::Bool(false)),
            opt("blocking", Default::Bool(false)),
        ],
        "Shows a popup (a message event; it never blocks here).",
        popup,
    ),
];

fn show(c: &mut Runtime, a: &mut Args, kind: MessageKind, text: String) -> Result<Out, Fault> {
    let given = a.positional.min(a.v.len());
    c.events.push_back(Event::Message(Message {
        line: a.line,
        kind,
        text,
        args: a.v[..given].to_vec(),
    }));
    Ok(Out::Value(Value::None))
}

fn textmsg(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let text = format!("{}{}", a.v[0].to_str(), a.v[1].to_str());
    show(c, a, MessageKind::Textmsg, text)
}

fn varmsg(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let text = format!("{} = {}", a.v[0].to_str(), a.v[1].to_str());
    show(c, a, MessageKind::Varmsg, text)
}

fn popup(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let kind = MessageKind::Popup {
        title: a.v[1].to_str(),
        warning: a.boolean(2)?,
        error: a.boolean(3)?,
        blocking: a.boolean(4)?,
    };
    let text = a.v[0].to_str();
    show(c, a, kind, text)
}
