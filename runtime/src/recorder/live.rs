//! Live view: the recorder's channels served to Foxglove over its WebSocket protocol (the
//! `foxglove` crate's server). The writer thread hands every message it has just encoded for the
//! file to [`LiveView::publish`] as well, so a viewer sees exactly what is recorded, with the same
//! schemas, and a producer (a real-time thread) never waits for a viewer: the writer thread is
//! the only one that touches the server, and the server's own tokio threads send to clients from
//! bounded per-client queues.
//!
//! Viewers offering either name of the protocol connect: `foxglove.sdk.v1` (Foxglove today) and
//! `foxglove.websocket.v1` (Lichtblick, older Foxglove Studio, `@foxglove/ws-protocol` clients).
//! The crate's server accepts only the first, so it listens on loopback and the public port is a
//! front that renames the second during the handshake ([`super::live_front`]); past the handshake
//! both get the same server's bytes.
//!
//! Connect: Foxglove → *Open connection* → *Foxglove WebSocket* → `ws://HOST:PORT` (default
//! port 8765), then load `config/foxglove-layout.json`. Messages written once (ground truth, the
//! navigation grid) are published again every `recorder.stats_interval_s` for viewers that
//! connect later.

use super::RecorderError;
use super::live_front::Front;
use super::schemas::ChannelDef;
use foxglove::{Context, PartialMetadata, RawChannel, WebSocketServer, WebSocketServerHandle};
use std::net::{Ipv4Addr, SocketAddr};
use std::sync::Arc;

/// A running live-view server and one channel per recorded topic.
pub struct LiveView {
    _ctx: Arc<Context>,
    server: Option<WebSocketServerHandle>,
    front: Option<Front>,
    channels: Vec<Arc<RawChannel>>,
    port: u16,
}

impl std::fmt::Debug for LiveView {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveView")
            .field("port", &self.port)
            .field("channels", &self.channels.len())
            .finish_non_exhaustive()
    }
}

impl LiveView {
    /// Serve `channels` on `0.0.0.0:port` (port 0: any free port, see [`LiveView::port`]).
    pub fn start(port: u16, channels: &[ChannelDef]) -> Result<Self, RecorderError> {
        let err = |e: foxglove::FoxgloveError| RecorderError::Live(e.to_string());
        let ctx = Context::new();
        let chans = channels
            .iter()
            .map(|c| {
                ctx.channel_builder(c.topic)
                    .message_encoding(c.encoding.clone())
                    .schema(c.schema.clone())
                    .build_raw()
                    .map_err(err)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let server = WebSocketServer::new()
            .name("vpsom-rt")
            .context(&ctx)
            .bind("127.0.0.1", 0)
            .start_blocking()
            .map_err(err)?;
        let backend = SocketAddr::from((Ipv4Addr::LOCALHOST, server.port()));
        let front = Front::start("0.0.0.0", port, backend)
            .map_err(|e| RecorderError::Live(format!("port {port}: {e}")))?;
        let port = front.port();
        Ok(Self {
            _ctx: ctx,
            server: Some(server),
            front: Some(front),
            channels: chans,
            port,
        })
    }

    /// The port being served.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// Viewers connected now.
    pub fn clients(&self) -> usize {
        self.server
            .as_ref()
            .map_or(0, WebSocketServerHandle::client_count)
    }

    /// Publish one encoded message of channel `index` (the order of the file's channels).
    pub(super) fn publish(&self, index: usize, log_ns: u64, data: &[u8]) {
        if let Some(c) = self.channels.get(index)
            && c.has_sinks()
        {
            c.log_with_meta(
                data,
                PartialMetadata {
                    log_time: Some(log_ns),
                },
            );
        }
    }
}

impl Drop for LiveView {
    fn drop(&mut self) {
        if let Some(s) = self.server.take() {
            // Dropping the shutdown handle aborts the client tasks at once.
            drop(s.stop());
        }
        drop(self.front.take());
    }
}
