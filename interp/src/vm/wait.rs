//! The driver's inputs (a connection up or failed, bytes received, a peer closed) and the
//! waits they end: socket reads, `socket_open`, XML-RPC calls (`handle.name(...)`).

use super::{Machine, Thread, Wait};
use crate::error::{Fault, RuntimeError, RuntimeErrorKind as K};
use crate::event::{CallRecord, Event, Outcome, ReadRecord, MAX_READ_INPUT};
use crate::value::size::check_value;
use crate::value::Value;

impl Machine {
    /// The driver's answer to [`Event::Connect`]: the connection is up, or failed with a
    /// reason (then `socket_open` returns `False` and the program goes on).
    pub fn handle_connected(&mut self, socket_name: &str, result: Result<(), String>) {
        if self.rpc_connected(socket_name, &result) {
            return;
        }
        let ok = result.is_ok();
        if ok {
            self.ctl.sockets.open(socket_name);
        }
        for t in &mut self.threads {
            let Wait::Connect { socket, record } = &mut t.wait else {
                continue;
            };
            if socket != socket_name {
                continue;
            }
            if let Some(mut r) = record.take() {
                r.result = Value::Bool(ok);
                if let Err(why) = &result {
                    r.outcome = Outcome::Failed(why.clone());
                }
                self.ctl.events.push_back(Event::Call(r));
            }
            t.wait = Wait::Resume(Value::Bool(ok));
        }
    }

    /// Bytes the server sent on `socket_name`. Returns how many the socket's receive
    /// buffer accepted (the rest must be offered again later, as a full TCP window would).
    pub fn handle_received(&mut self, socket_name: &str, bytes: &[u8]) -> usize {
        if self.rpc_event(socket_name, Some(bytes)) {
            return bytes.len();
        }
        let n = self.ctl.sockets.receive(socket_name, bytes);
        // A recorded read waiting on the socket sees what arrived.
        for t in &mut self.threads {
            if let Wait::Read {
                socket,
                record: Some(_),
                input,
                ..
            } = &mut t.wait
            {
                if socket == socket_name {
                    let room = MAX_READ_INPUT.saturating_sub(input.len());
                    input.extend_from_slice(&bytes[..n.min(room)]);
                }
            }
        }
        self.poll_reads(socket_name);
        n
    }

    /// The server closed `socket_name`: reads waiting on it end with their sentinels.
    pub fn handle_peer_closed(&mut self, socket_name: &str) {
        if self.rpc_event(socket_name, None) {
            return;
        }
        self.ctl.sockets.peer_closed(socket_name);
        self.poll_reads(socket_name);
    }

    /// Writing to `socket_name` failed (the peer is gone): later `socket_send_*` calls
    /// on it return `False`, and reads waiting on it end with their sentinels.
    pub fn handle_send_failed(&mut self, socket_name: &str) {
        self.ctl.sockets.send_failed(socket_name);
        self.handle_peer_closed(socket_name);
    }

    /// The connection of an XML-RPC call is up (its request goes out) or failed (the
    /// call fails). False if no call waits for `socket_name`.
    fn rpc_connected(&mut self, socket_name: &str, result: &Result<(), String>) -> bool {
        let Some(t) = self
            .threads
            .iter_mut()
            .find(|t| !t.done && matches!(&t.wait, Wait::Rpc(p) if p.socket == socket_name))
        else {
            // A late answer for a call that already ended (timed out, its thread killed)
            // opens nothing; a `socket_open` of such a name still gets its own.
            let connecting = self.threads.iter().any(|t| {
                !t.done && matches!(&t.wait, Wait::Connect { socket, .. } if socket == socket_name)
            });
            return socket_name.starts_with("rpc:") && !connecting;
        };
        let Wait::Rpc(p) = &mut t.wait else {
            return false;
        };
        match result {
            Ok(()) => {
                if let Some(bytes) = p.request.take() {
                    self.ctl.events.push_back(Event::Transmit {
                        socket_name: socket_name.to_string(),
                        bytes,
                    });
                }
            }
            Err(why) => {
                let msg = p.failure(&format!("could not connect: {why}"));
                t.wait = rpc_done(
                    &mut self.ctl.events,
                    p,
                    Err(msg),
                    self.config.max_value_size,
                );
            }
        }
        true
    }

    /// Bytes (`Some`) or the peer's close (`None`) on `socket_name`, for the XML-RPC
    /// call waiting on it: the call ends when its reply is complete, malformed or cut
    /// short. False if no call waits for `socket_name`.
    fn rpc_event(&mut self, socket_name: &str, bytes: Option<&[u8]>) -> bool {
        let Some(t) = self
            .threads
            .iter_mut()
            .find(|t| !t.done && matches!(&t.wait, Wait::Rpc(p) if p.socket == socket_name))
        else {
            return false;
        };
        let Wait::Rpc(p) = &mut t.wait else {
            return false;
        };
        let reply = match bytes {
            Some(b) => p.receive(b),
            None => crate::rpc::reply(&p.reply, true),
        };
        let outcome = match reply {
            crate::rpc::Reply::Incomplete => return true,
            crate::rpc::Reply::Value(v) => Ok(v),
            crate::rpc::Reply::Error(e) => Err(p.failure(&e)),
        };
        t.wait = rpc_done(&mut self.ctl.events, p, outcome, self.config.max_value_size);
        true
    }

    /// Completes a read waiting on `socket_name` if its bytes are there.
    fn poll_reads(&mut self, socket_name: &str) {
        for t in &mut self.threads {
            let Wait::Read {
                socket,
                call,
                record,
                input,
                buffered_at_start,
            } = &mut t.wait
            else {
                continue;
            };
            if socket != socket_name || t.done {
                continue;
            }
            if let Some(r) = self.ctl.sockets.poll(socket_name) {
                let v = crate::sockets::to_value(&r);
                if let Some(mut rec) = record.take() {
                    rec.result = v.clone();
                    rec.read = Some(ReadRecord {
                        call: call.clone(),
                        result: r,
                        input: std::mem::take(input),
                        buffered_at_start: *buffered_at_start,
                    });
                    self.ctl.events.push_back(Event::Call(rec));
                }
                t.wait = Wait::Resume(v);
            }
        }
    }

    /// Names of the sockets open now.
    pub fn open_sockets(&self) -> Vec<String> {
        self.ctl.sockets.open_names()
    }

    /// `target.method(args)`: an XML-RPC call. `Ok(Some(v))` returns at once
    /// (`closeXMLRPCClientConnection()`), `Ok(None)`: the thread waits (its wait is set).
    pub(super) fn rpc_call(
        &mut self,
        th: &mut Thread,
        target: Value,
        method: &str,
        args: Vec<Value>,
        at: crate::syntax::compile::Pos,
    ) -> Result<Option<Value>, RuntimeError> {
        let fail = |f: Fault| RuntimeError::at(at.line, at.col, f);
        let Value::Rpc(url) = target else {
            return Err(fail(Fault::new(
                K::Type,
                format!(
                    "type error: `.{method}(...)` calls a remote procedure on an rpc_factory handle, not on a {}",
                    target.type_name()
                ),
            )));
        };
        // Every call has its own connection (closed when its reply is in), so there is
        // nothing to close.
        if method == "closeXMLRPCClientConnection" && args.is_empty() {
            return Ok(Some(Value::None));
        }
        // The controller's own EtherNet/IP adapter service answers in-process.
        if crate::rpc::parse_url(&url).is_ok_and(|u| crate::eip::is_service(&u)) {
            let connected = self.ctl.arm.world.eip_connected;
            return crate::eip::service_call(&mut self.ctl.arm.eip, connected, method, &args)
                .map(Some)
                .map_err(|e| {
                    fail(Fault::new(
                        K::RemoteCall,
                        format!("XML-RPC call `{method}` to {url}: {e}"),
                    ))
                });
        }
        let socket = crate::rpc::socket_name(&url);
        if self
            .threads
            .iter()
            .any(|t| !t.done && matches!(&t.wait, Wait::Rpc(p) if p.socket == socket))
        {
            return Err(fail(Fault::new(
                K::RemoteCall,
                format!("XML-RPC call `{method}` to {url}: another thread's call to this server is under way"),
            )));
        }
        let parsed = crate::rpc::parse_url(&url).map_err(|e| fail(Fault::from(e)))?;
        let request = crate::rpc::request(&parsed, method, &args).map_err(|e| {
            fail(Fault::type_error(format!(
                "XML-RPC call `{method}` to {url}: {e}"
            )))
        })?;
        let record = (self.config.trace_socket_calls || self.config.trace_all_calls).then(|| {
            Box::new(CallRecord {
                line: at.line,
                column: at.col,
                // `rpc_factory("xmlrpc", "URL").name`: the call as the program could
                // write it, never mistaken for a built-in.
                name: format!("{}.{method}", Value::Rpc(url.clone()).to_source()),
                builtin: None,
                args: args.clone(),
                kwargs: Vec::new(),
                assigned_to: None,
                result: Value::None,
                outcome: Outcome::Returned,
                socket: Some(socket.clone()),
                read: None,
            })
        });
        self.ctl.events.push_back(Event::Connect {
            socket_name: socket.clone(),
            host: parsed.host,
            port: parsed.port,
        });
        let deadline = self
            .ctl
            .step
            .saturating_add(self.steps_for(crate::rpc::TIMEOUT));
        th.wait = Wait::Rpc(Box::new(crate::rpc::Pending {
            socket,
            url,
            method: method.to_string(),
            request: Some(request),
            reply: Vec::new(),
            deadline,
            line: at.line,
            col: at.col,
            record,
        }));
        Ok(None)
    }
}

/// The end of an XML-RPC call: its connection closes, its record (if traced) is
/// emitted, and the thread resumes with the value or stops with the error.
pub(super) fn rpc_done(
    events: &mut super::memory::Events,
    p: &mut crate::rpc::Pending,
    outcome: Result<Value, String>,
    max_size: usize,
) -> Wait {
    // The reply's value is within the value bounds, as every value the program holds.
    let outcome = outcome.and_then(|v| {
        check_value(&v, max_size)
            .map(|()| v)
            .map_err(|f| p.failure(&f.message))
    });
    events.push_back(Event::Close {
        socket_name: p.socket.clone(),
    });
    if let Some(mut r) = p.record.take() {
        match &outcome {
            Ok(v) => r.result = v.clone(),
            Err(why) => r.outcome = Outcome::Failed(why.clone()),
        }
        events.push_back(Event::Call(r));
    }
    match outcome {
        Ok(v) => Wait::Resume(v),
        Err(msg) => Wait::Failed(Box::new(RuntimeError::at(
            p.line,
            p.col,
            Fault::new(K::RemoteCall, msg),
        ))),
    }
}
