//! The live view's public port: a front that lets viewers offering either name of Foxglove's
//! WebSocket protocol reach the one `foxglove` server.
//!
//! The `foxglove` crate's server (0.30.3, the newest release; no feature or option changes this)
//! negotiates only `foxglove.sdk.v1` and `foxglove.sdk.v1.1`. Viewers built on
//! `@foxglove/ws-protocol` (Lichtblick, Foxglove Studio before the rename, `FoxgloveClient`'s
//! default) offer only `foxglove.websocket.v1`, and the server refuses them with HTTP 400. The two
//! names are the same protocol: `foxglove.sdk.v1` is `foxglove.websocket.v1` renamed (inline
//! schemas in `advertise`, the same JSON and binary messages), as Foxglove says and as Lichtblick's
//! support for the new name (one string added) relies on.
//!
//! So the crate's server listens on loopback only, and the live port is this front. For each
//! connection it reads the HTTP upgrade request and, when the client offers
//! `foxglove.websocket.v1` and no `foxglove.sdk.*` name, offers `foxglove.sdk.v1` in its place; in
//! the server's `101` answer it names `foxglove.websocket.v1` again. Every other byte, before and
//! after the handshake, passes unchanged in both directions, so every client gets the same
//! advertisements, subscriptions and encoded messages from the same server, whose per-client
//! queues drop the oldest messages for a slow client: nothing here makes the recorder thread (or
//! any real-time thread) wait for a viewer.
//!
//! Threads: `live-front` accepts; each connection has `live-up` (handshake, then client → server)
//! and `live-down` (server → client). Closing either side closes both.

use std::collections::HashMap;
use std::io::{self, Read, Write};
use std::net::{Ipv4Addr, Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

/// The name `@foxglove/ws-protocol` and the viewers built on it offer.
pub const LEGACY_SUBPROTOCOL: &str = "foxglove.websocket.v1";
/// The name the `foxglove` crate's server accepts for the same protocol.
pub const SDK_SUBPROTOCOL: &str = "foxglove.sdk.v1";
/// An upgrade request (or response) head longer than this is passed on unread.
const MAX_HEAD: usize = 16 * 1024;
/// A client must have sent its request head within this.
const HEAD_TIMEOUT: Duration = Duration::from_secs(10);

/// The front: a listener on the public port and the connections it relays.
pub(super) struct Front {
    port: u16,
    stop: Arc<AtomicBool>,
    conns: Arc<Mutex<HashMap<u64, TcpStream>>>,
    accept: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for Front {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Front").field("port", &self.port).finish()
    }
}

impl Front {
    /// Listen on `host:port` (port 0: any free port) and relay every connection to `backend`.
    pub(super) fn start(host: &str, port: u16, backend: SocketAddr) -> io::Result<Self> {
        let listener = TcpListener::bind((host, port))?;
        let port = listener.local_addr()?.port();
        let stop = Arc::new(AtomicBool::new(false));
        let conns: Arc<Mutex<HashMap<u64, TcpStream>>> = Arc::default();
        let accept = {
            let (stop, conns) = (Arc::clone(&stop), Arc::clone(&conns));
            std::thread::Builder::new()
                .name("live-front".into())
                .spawn(move || accept_loop(&listener, backend, &stop, &conns))?
        };
        Ok(Self {
            port,
            stop,
            conns,
            accept: Some(accept),
        })
    }

    /// The public port.
    pub(super) fn port(&self) -> u16 {
        self.port
    }
}

impl Drop for Front {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        // Wake the accepting thread; it sees the flag and returns, closing the listener.
        let _ = TcpStream::connect((Ipv4Addr::LOCALHOST, self.port));
        if let Some(t) = self.accept.take() {
            let _ = t.join();
        }
        let conns = std::mem::take(&mut *self.conns.lock().unwrap_or_else(|e| e.into_inner()));
        for c in conns.values() {
            let _ = c.shutdown(Shutdown::Both);
        }
    }
}

fn accept_loop(
    listener: &TcpListener,
    backend: SocketAddr,
    stop: &AtomicBool,
    conns: &Arc<Mutex<HashMap<u64, TcpStream>>>,
) {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    for client in listener.incoming() {
        if stop.load(Ordering::SeqCst) {
            return;
        }
        let client = match client {
            Ok(c) => c,
            Err(_) => {
                // Out of descriptors or the like: do not spin.
                std::thread::sleep(Duration::from_millis(50));
                continue;
            }
        };
        let id = NEXT.fetch_add(1, Ordering::Relaxed);
        if let Ok(c) = client.try_clone() {
            conns
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .insert(id, c);
        }
        let spawned = {
            let conns = Arc::clone(conns);
            std::thread::Builder::new()
                .name("live-up".into())
                .spawn(move || {
                    let _ = relay(&client, backend);
                    let _ = client.shutdown(Shutdown::Both);
                    conns.lock().unwrap_or_else(|e| e.into_inner()).remove(&id);
                })
        };
        if spawned.is_err() {
            eprintln!("live view: no thread for a viewer's connection; refused");
            if let Some(c) = conns.lock().unwrap_or_else(|e| e.into_inner()).remove(&id) {
                let _ = c.shutdown(Shutdown::Both);
            }
        }
    }
}

/// One connection: the handshake (renamed if need be), then bytes both ways until one side closes.
fn relay(client: &TcpStream, backend: SocketAddr) -> io::Result<()> {
    client.set_nodelay(true)?;
    client.set_read_timeout(Some(HEAD_TIMEOUT))?;
    let (head, rest) = read_head(&mut &*client)?;
    client.set_read_timeout(None)?;
    let server = TcpStream::connect(backend)?;
    server.set_nodelay(true)?;
    let renamed = std::str::from_utf8(&head).ok().and_then(rewrite_request);
    let legacy = renamed.is_some();
    (&server).write_all(renamed.as_ref().map_or(&head[..], String::as_bytes))?;
    (&server).write_all(&rest)?;
    let down = {
        let (client, server) = (client.try_clone()?, server.try_clone()?);
        std::thread::Builder::new()
            .name("live-down".into())
            .spawn(move || {
                let _ = relay_down(&client, &server, legacy);
                let _ = server.shutdown(Shutdown::Both);
                let _ = client.shutdown(Shutdown::Both);
            })?
    };
    let _ = io::copy(&mut &*client, &mut &server);
    let _ = server.shutdown(Shutdown::Both);
    let _ = client.shutdown(Shutdown::Both);
    let _ = down.join();
    Ok(())
}

/// Server → client: the response head (renamed back for a legacy client), then everything else.
fn relay_down(client: &TcpStream, server: &TcpStream, legacy: bool) -> io::Result<()> {
    if legacy {
        let (head, rest) = read_head(&mut &*server)?;
        match std::str::from_utf8(&head) {
            Ok(h) => (&*client).write_all(rewrite_response(h).as_bytes())?,
            Err(_) => (&*client).write_all(&head)?,
        }
        (&*client).write_all(&rest)?;
    }
    io::copy(&mut &*server, &mut &*client)?;
    Ok(())
}

/// Read up to the end of an HTTP head (`\r\n\r\n`): the head and what followed it. A head
/// longer than [`MAX_HEAD`] is an error (the connection is closed).
fn read_head(r: &mut impl Read) -> io::Result<(Vec<u8>, Vec<u8>)> {
    let mut buf = Vec::with_capacity(1024);
    let mut chunk = [0u8; 2048];
    loop {
        let n = r.read(&mut chunk)?;
        if n == 0 {
            return Err(io::ErrorKind::UnexpectedEof.into());
        }
        let from = buf.len().saturating_sub(3);
        buf.extend_from_slice(&chunk[..n]);
        if let Some(i) = buf[from..].windows(4).position(|w| w == b"\r\n\r\n") {
            let end = from + i + 4;
            let rest = buf.split_off(end);
            return Ok((buf, rest));
        }
        if buf.len() > MAX_HEAD {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                "HTTP head too long",
            ));
        }
    }
}

fn is_protocol_header(line: &str) -> Option<&str> {
    let (name, value) = line.split_once(':')?;
    name.trim()
        .eq_ignore_ascii_case("sec-websocket-protocol")
        .then_some(value)
}

/// The request head with `foxglove.websocket.v1` offered as `foxglove.sdk.v1`, if the client
/// offers the legacy name and no `foxglove.sdk.*` one; `None` to pass the head on unchanged.
fn rewrite_request(head: &str) -> Option<String> {
    let offered: Vec<&str> = head
        .split("\r\n")
        .filter_map(is_protocol_header)
        .flat_map(|v| v.split(','))
        .map(str::trim)
        .collect();
    if !offered.contains(&LEGACY_SUBPROTOCOL)
        || offered.iter().any(|p| p.starts_with("foxglove.sdk."))
    {
        return None;
    }
    let lines = head.split("\r\n").map(|line| {
        if is_protocol_header(line).is_some() {
            format!("Sec-WebSocket-Protocol: {SDK_SUBPROTOCOL}")
        } else {
            line.to_string()
        }
    });
    Some(lines.collect::<Vec<_>>().join("\r\n"))
}

/// The server's response head with the negotiated `foxglove.sdk.v1` named
/// `foxglove.websocket.v1`, as the legacy client asked (any other head unchanged).
fn rewrite_response(head: &str) -> String {
    let lines = head
        .split("\r\n")
        .map(|line| match is_protocol_header(line) {
            Some(v) if v.trim() == SDK_SUBPROTOCOL => {
                format!("Sec-WebSocket-Protocol: {LEGACY_SUBPROTOCOL}")
            }
            _ => line.to_string(),
        });
    lines.collect::<Vec<_>>().join("\r\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    const REQ: &str = "GET / HTTP/1.1\r\nHost: 127.0.0.1:8765\r\nUpgrade: websocket\r\n\
                       Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\
                       Sec-WebSocket-Version: 13\r\n";

    #[test]
    fn a_legacy_offer_is_renamed_and_nothing_else_changes() {
        let head = format!("{REQ}sec-websocket-protocol: {LEGACY_SUBPROTOCOL}\r\n\r\n");
        let out = rewrite_request(&head).expect("renamed");
        assert_eq!(
            out,
            format!("{REQ}Sec-WebSocket-Protocol: {SDK_SUBPROTOCOL}\r\n\r\n")
        );
    }

    #[test]
    fn an_offer_the_server_accepts_passes_unchanged() {
        for offer in [
            "foxglove.sdk.v1",
            "foxglove.sdk.v1.1, foxglove.sdk.v1",
            "foxglove.websocket.v1, foxglove.sdk.v1",
            "something.else",
        ] {
            let head = format!("{REQ}Sec-WebSocket-Protocol: {offer}\r\n\r\n");
            assert_eq!(rewrite_request(&head), None, "{offer}");
        }
        assert_eq!(rewrite_request(&format!("{REQ}\r\n")), None);
    }

    #[test]
    fn the_answer_names_the_legacy_protocol() {
        let head = "HTTP/1.1 101 Switching Protocols\r\nconnection: Upgrade\r\nupgrade: websocket\r\n\
                    sec-websocket-accept: s3pPLMBiTxaQ9kYGzzhZRbK+xOo=\r\n\
                    sec-websocket-protocol: foxglove.sdk.v1\r\n\r\n";
        let out = rewrite_response(head);
        assert_eq!(
            out,
            head.replace(
                "sec-websocket-protocol: foxglove.sdk.v1",
                "Sec-WebSocket-Protocol: foxglove.websocket.v1"
            )
        );
    }

    /// A stand-in for the crate's server: answers one upgrade with `foxglove.sdk.v1` if offered,
    /// then sends `data` and keeps the connection open.
    fn fake_backend(data: &'static [u8]) -> SocketAddr {
        let l = TcpListener::bind((Ipv4Addr::LOCALHOST, 0)).unwrap();
        let addr = l.local_addr().unwrap();
        std::thread::spawn(move || {
            let (mut s, _) = l.accept().unwrap();
            let (head, _) = read_head(&mut s).unwrap();
            let head = String::from_utf8(head).unwrap();
            assert!(
                head.contains("Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n"),
                "{head}"
            );
            let answer = "HTTP/1.1 101 Switching Protocols\r\nsec-websocket-protocol: foxglove.sdk.v1\r\n\r\n";
            s.write_all(answer.as_bytes()).unwrap();
            s.write_all(data).unwrap();
            // Hold the connection until the front closes it.
            let _ = s.read(&mut [0u8; 1]);
        });
        addr
    }

    #[test]
    fn a_legacy_client_is_relayed_and_dropping_the_front_closes_it_and_frees_the_port() {
        let front = Front::start("127.0.0.1", 0, fake_backend(b"\x01payload")).unwrap();
        let port = front.port();
        let mut c = TcpStream::connect((Ipv4Addr::LOCALHOST, port)).unwrap();
        c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        c.write_all(
            format!("{REQ}Sec-WebSocket-Protocol: {LEGACY_SUBPROTOCOL}\r\n\r\n").as_bytes(),
        )
        .unwrap();
        let (head, mut rest) = read_head(&mut c).unwrap();
        let head = String::from_utf8(head).unwrap();
        assert!(
            head.contains("Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n"),
            "{head}"
        );
        while rest.len() < 8 {
            let mut b = [0u8; 64];
            let n = c.read(&mut b).unwrap();
            assert!(n > 0, "closed early");
            rest.extend_from_slice(&b[..n]);
        }
        assert_eq!(rest, b"\x01payload");
        drop(front);
        // The viewer's connection is closed, and the port is free again.
        assert_eq!(c.read(&mut [0u8; 8]).unwrap(), 0);
        TcpListener::bind((Ipv4Addr::LOCALHOST, port)).expect("the port is freed");
    }

    #[test]
    fn a_head_is_read_to_its_end_and_the_rest_kept() {
        let data = b"GET / HTTP/1.1\r\nA: b\r\n\r\n\x81\x02hi";
        let (head, rest) = read_head(&mut &data[..]).unwrap();
        assert_eq!(head, b"GET / HTTP/1.1\r\nA: b\r\n\r\n");
        assert_eq!(rest, b"\x81\x02hi");
        assert!(read_head(&mut &b"GET / HTTP/1.1\r\n"[..]).is_err());
    }
}
