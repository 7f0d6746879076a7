//! The live view: a WebSocket client speaking Foxglove's protocol connects to a recording's
//! live-view server, finds every channel advertised with Foxglove's protobuf schemas,
//! subscribes, and receives depth images (`foxglove.RawImage`) and maps (`foxglove.SceneUpdate`)
//! that decode to what was recorded. Once under each name of the protocol: `foxglove.sdk.v1`
//! (the `foxglove` crate's) and `foxglove.websocket.v1` (Lichtblick's and `@foxglove/ws-protocol`'s,
//! refused with HTTP 400 before the live view's front renamed it: issue 36).

#[path = "../../../runtime/tests/recorder_common/mod.rs"]
mod recorder_common;

use foxglove::Decode;
use foxglove::messages::{RawImage, SceneUpdate};
use recorder_common::*;
use runtime::recorder::{Recorder, RecorderConfig, RecorderSetup};
use serde_json::{Value, json};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use tungstenite::client::IntoClientRequest;
use tungstenite::{Message, stream::MaybeTlsStream};
use vpsom::recording::{MountGeometry, SceneConverter, topic};

#[test]
fn a_foxglove_client_sees_the_channels_and_receives_images_and_scenes() {
    client_sees_channels_and_receives_images_and_scenes("foxglove.sdk.v1");
}

#[test]
fn a_legacy_ws_protocol_client_is_served_the_same() {
    client_sees_channels_and_receives_images_and_scenes("foxglove.websocket.v1");
}

fn client_sees_channels_and_receives_images_and_scenes(subprotocol: &str) {
    let dir = std::env::temp_dir().join(format!(
        "vpsom-recorder-live-{}-{subprotocol}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let cfg = RecorderConfig::default();
    let conv = SceneConverter::new(&cfg, MountGeometry::default(), Vec::new());
    let setup = RecorderSetup {
        live_port: Some(0),
        ..RecorderSetup::new(conv)
    };
    let rec = Recorder::create(&dir.join("trace.mcap"), &cfg, setup).unwrap();
    let port = rec.live_port().expect("a live view was asked for");
    // A producer recording as a robot does, until the client is done.
    let stop = Arc::new(AtomicBool::new(false));
    let producer = {
        let (h, stop) = (rec.handle(), Arc::clone(&stop));
        std::thread::spawn(move || {
            let mut i = 1;
            while !stop.load(Ordering::Relaxed) {
                h.record_depth(&depth(i, 64, 48));
                h.record_map(&map(i, 3));
                i += 1;
                std::thread::sleep(Duration::from_millis(20));
            }
        })
    };

    let mut req = format!("ws://127.0.0.1:{port}")
        .into_client_request()
        .unwrap();
    req.headers_mut()
        .insert("Sec-WebSocket-Protocol", subprotocol.parse().unwrap());
    let (mut ws, resp) = tungstenite::connect(req).expect("connect to the live view");
    assert_eq!(
        resp.headers()["sec-websocket-protocol"],
        subprotocol,
        "the server names the protocol the client offered"
    );
    if let MaybeTlsStream::Plain(s) = ws.get_ref() {
        s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    }
    // Hang guard, generous on purpose (a loaded machine): 60 s for the whole exchange.
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut channels: Vec<Value> = Vec::new();
    while channels.len() < vpsom::recording::channels().len() {
        assert!(Instant::now() < deadline, "no advertisement: {channels:?}");
        if let Ok(Message::Text(t)) = ws.read() {
            let v: Value = serde_json::from_str(&t).unwrap();
            if v["op"] == "advertise" {
                channels.extend(v["channels"].as_array().unwrap().iter().cloned());
            }
        }
    }
    let chan = |t: &str| {
        channels
            .iter()
            .find(|c| c["topic"] == t)
            .unwrap_or_else(|| panic!("{t} not advertised: {channels:?}"))
            .clone()
    };
    let (img, scene) = (chan(topic::DEPTH), chan(topic::MAP));
    assert_eq!(img["schemaName"], "foxglove.RawImage");
    assert_eq!(img["encoding"], "protobuf");
    assert_eq!(img["schemaEncoding"], "protobuf");
    assert_eq!(scene["schemaName"], "foxglove.SceneUpdate");
    assert_eq!(
        chan(topic::DECISIONS)["schemaName"],
        "plannerdecision.PlannerDecision"
    );
    let sub = json!({"op": "subscribe", "subscriptions": [
        {"id": 1, "channelId": img["id"]},
        {"id": 2, "channelId": scene["id"]},
    ]});
    ws.send(Message::Text(sub.to_string().into())).unwrap();

    let (mut got_img, mut got_scene) = (None, None);
    while got_img.is_none() || got_scene.is_none() {
        assert!(Instant::now() < deadline, "no data: image {got_img:?}");
        let Ok(Message::Binary(b)) = ws.read() else {
            continue;
        };
        // Message data: opcode 1, subscription id (u32 LE), log time (u64 LE), payload.
        if b.len() < 13 || b[0] != 1 {
            continue;
        }
        let sub = u32::from_le_bytes(b[1..5].try_into().unwrap());
        let payload = &b[13..];
        match sub {
            1 => got_img = Some(RawImage::decode(payload).unwrap()),
            2 => got_scene = Some(SceneUpdate::decode(payload).unwrap()),
            other => panic!("subscription {other} was never asked for"),
        }
    }
    let img = got_img.unwrap();
    assert_eq!(
        (img.width, img.height, &img.encoding[..]),
        (64, 48, "16UC1")
    );
    assert_eq!(img.data.len(), 64 * 48 * 2);
    assert_eq!(got_scene.unwrap().entities.len(), 3);

    stop.store(true, Ordering::Relaxed);
    producer.join().unwrap();
    let _ = ws.close(None);
    let summary = rec.finish().unwrap();
    assert!(summary.written[topic::DEPTH] >= 1);
    let _ = std::fs::remove_dir_all(&dir);
}
