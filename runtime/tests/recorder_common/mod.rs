//! Shared helpers of the recorder tests: message builders, a reader of every message with its
//! schema, and a small JSON Schema validator for the keywords our schemas use.

#![allow(dead_code)]

use runtime::recorder::inspect::{Item, ScanEnd, scan};
use serde_json::Value;
use shm_types::*;
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

pub fn header(seq: u64) -> Header {
    Header {
        seq,
        stamp_ns: 1_000 + seq * 7,
        sim_time_ns: seq * 33_333_333,
    }
}

pub fn depth(seq: u64, w: u32, h: u32) -> Box<DepthFrame> {
    let mut f = boxed_zeroed::<DepthFrame>();
    f.header = header(seq);
    f.width = w;
    f.height = h;
    f.intrinsics = Intrinsics {
        fx: 500.0,
        fy: 500.0,
        cx: w as f32 / 2.0,
        cy: h as f32 / 2.0,
        min_range: 0.5,
        max_range: 5.0,
    };
    for (i, p) in f.pixels_mut().iter_mut().enumerate() {
        *p = 500 + ((i as u64 * 13 + seq * 101) % 4000) as u16;
    }
    f
}

pub fn state(seq: u64) -> RobotState {
    let t = seq as f32 * 0.02;
    RobotState {
        header: header(seq),
        base_pose: [t.cos() * 2.0, t.sin() * 2.0, t + 1.57],
        neck_yaw: (t * 3.0).sin(),
        neck_pitch: 0.49,
        localization_ok: 1,
        ..Default::default()
    }
}

pub fn map(seq: u64, objects: usize) -> Box<ObjectMap> {
    let mut m = boxed_zeroed::<ObjectMap>();
    m.header = header(seq);
    m.count = objects as u32;
    m.eps_sopm = 0.3;
    for (k, o) in m.objects[..objects].iter_mut().enumerate() {
        o.id = k as u32 + 1;
        o.class_id = (k * 7 % 80) as u16;
        o.center = [k as f32 * 0.5, -1.0, 0.4];
        o.size = [0.3, 0.2, 0.25];
        o.yaw = 0.1 * k as f32;
        o.h_sopm = 0.9 - 0.01 * k as f32;
        o.complete = u8::from(k % 3 == 0);
        o.cluster_id = -1;
    }
    m
}

pub fn decision(seq: u64, kind: u8, n: usize) -> Box<PlannerDecision> {
    let mut d = boxed_zeroed::<PlannerDecision>();
    d.header = header(seq);
    d.kind = kind;
    d.count = n as u32;
    d.evaluated = n as u32 * 2;
    d.cluster_id = 3;
    for (k, c) in d.candidates[..n].iter_mut().enumerate() {
        c.position = [k as f32 * 0.1, 0.5, 1.4];
        c.yaw = k as f32 * 0.3;
        c.pitch = 0.49;
        c.value = k as f32;
        c.f_a = 0.5;
        c.f_c = 0.25;
        c.h_sopm = 2.0;
        c.objects_in_view = k as u16;
        c.chosen = u8::from(k == n - 1);
        c.dropped = u8::from(k == 0);
    }
    d
}

pub fn deadline(seq: u64) -> DeadlineEvent {
    let mut e = DeadlineEvent {
        header: header(seq),
        cycle: seq,
        period_ns: 50_000_000,
        budget_ns: 20_000_000,
        lateness_ns: -5 + seq as i64,
        exec_ns: 1_000_000 + seq * 10,
        missed: u8::from(seq.is_multiple_of(10)),
        ..Default::default()
    };
    e.set_thread_name("lbv");
    e
}

/// One message read back.
#[derive(Debug, Clone)]
pub struct ReadMessage {
    pub topic: String,
    pub schema_name: String,
    pub schema: Value,
    pub log_time: u64,
    pub value: Value,
}

/// Every message of a file with its channel's schema (JSON only), and how the scan ended.
pub fn read_all(path: &Path) -> (Vec<ReadMessage>, ScanEnd) {
    let mut schemas: HashMap<u16, (String, Value)> = HashMap::new();
    let mut chans: HashMap<u16, (String, String, Value)> = HashMap::new();
    let mut out = Vec::new();
    let end = scan(path, |item| match item {
        Item::Schema {
            id,
            name,
            encoding,
            data,
        } => {
            assert_eq!(encoding, "jsonschema", "{name}");
            let v: Value = serde_json::from_slice(data).expect("schema is JSON");
            schemas.insert(id, (name.to_string(), v));
        }
        Item::Channel {
            id,
            topic,
            encoding,
            schema_id,
            ..
        } => {
            assert_eq!(encoding, "json", "{topic}");
            let (n, s) = schemas
                .get(&schema_id)
                .cloned()
                .expect("schema before channel");
            chans.insert(id, (topic.to_string(), n, s));
        }
        Item::Message {
            channel,
            log_time,
            data,
        } => {
            let (t, n, s) = chans
                .get(&channel)
                .cloned()
                .expect("channel before message");
            let value = serde_json::from_slice(data)
                .unwrap_or_else(|e| panic!("{t}: message is not JSON: {e}"));
            out.push(ReadMessage {
                topic: t,
                schema_name: n,
                schema: s,
                log_time,
                value,
            });
        }
        Item::Metadata { .. } => {}
    })
    .expect("scan");
    (out, end)
}

pub fn counts(msgs: &[ReadMessage]) -> BTreeMap<String, u64> {
    let mut c = BTreeMap::new();
    for m in msgs {
        *c.entry(m.topic.clone()).or_insert(0) += 1;
    }
    c
}

/// Validate `v` against `schema` (keywords: type, properties, required, items, enum, minimum,
/// maximum, minItems, maxItems, additionalProperties). Returns the first violation.
pub fn validate(schema: &Value, v: &Value, at: &str) -> Result<(), String> {
    let err = |m: String| Err(format!("{at}: {m}"));
    if let Some(t) = schema.get("type") {
        let types: Vec<&str> = match t {
            Value::String(s) => vec![s.as_str()],
            Value::Array(a) => a.iter().filter_map(Value::as_str).collect(),
            _ => return err("bad type keyword".into()),
        };
        let ok = types.iter().any(|t| match *t {
            "object" => v.is_object(),
            "array" => v.is_array(),
            "string" => v.is_string(),
            "integer" => v.is_i64() || v.is_u64(),
            "number" => v.is_number(),
            "boolean" => v.is_boolean(),
            "null" => v.is_null(),
            _ => false,
        });
        if !ok {
            return err(format!("{v} is not of type {t}"));
        }
    }
    if let Some(Value::Array(e)) = schema.get("enum")
        && !e.contains(v)
    {
        return err(format!("{v} not in {e:?}"));
    }
    if let (Some(lo), Some(x)) = (schema.get("minimum").and_then(Value::as_f64), v.as_f64())
        && x < lo
    {
        return err(format!("{x} < minimum {lo}"));
    }
    if let (Some(hi), Some(x)) = (schema.get("maximum").and_then(Value::as_f64), v.as_f64())
        && x > hi
    {
        return err(format!("{x} > maximum {hi}"));
    }
    if let Some(obj) = v.as_object() {
        if let Some(Value::Array(req)) = schema.get("required") {
            for r in req.iter().filter_map(Value::as_str) {
                if !obj.contains_key(r) {
                    return err(format!("missing required {r}"));
                }
            }
        }
        let props = schema.get("properties").and_then(Value::as_object);
        for (k, x) in obj {
            match props.and_then(|p| p.get(k)) {
                Some(s) => validate(s, x, &format!("{at}.{k}"))?,
                None => match schema.get("additionalProperties") {
                    Some(Value::Bool(false)) => return err(format!("unexpected property {k}")),
                    Some(s @ Value::Object(_)) => validate(s, x, &format!("{at}.{k}"))?,
                    _ => {}
                },
            }
        }
    }
    if let Some(arr) = v.as_array() {
        if let Some(n) = schema.get("minItems").and_then(Value::as_u64)
            && (arr.len() as u64) < n
        {
            return err(format!("fewer than {n} items"));
        }
        if let Some(n) = schema.get("maxItems").and_then(Value::as_u64)
            && (arr.len() as u64) > n
        {
            return err(format!("more than {n} items"));
        }
        if let Some(s) = schema.get("items") {
            for (i, x) in arr.iter().enumerate() {
                validate(s, x, &format!("{at}[{i}]"))?;
            }
        }
    }
    Ok(())
}

/// Run `runtime/tests/py/check_mcap.py` on `path` with the python in `VPSOM_PYTHON`, expecting
/// `expect` messages per topic. Only the `#[ignore]`d Python tests call it (`.ci/run` runs them
/// with `--ignored` after making a venv); without `VPSOM_PYTHON` it fails, never skips.
pub fn python_check(path: &Path, expect: &BTreeMap<String, u64>) {
    let py = std::env::var_os("VPSOM_PYTHON").expect(
        "precondition: VPSOM_PYTHON must name a python with the `mcap` and `jsonschema` \
         packages (.ci/run makes target/ci-venv)",
    );
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/py/check_mcap.py");
    let mut cmd = std::process::Command::new(py);
    cmd.arg(&script).arg(path);
    for (t, n) in expect {
        cmd.arg("--expect-topic").arg(format!("{t}={n}"));
    }
    let out = cmd.output().expect("run python");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "check_mcap.py failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let counts: BTreeMap<String, u64> =
        serde_json::from_str(stdout.trim()).expect("check_mcap.py prints counts as JSON");
    assert_eq!(&counts, expect, "python counts");
}

/// Messages per topic read through the file's index (summary section → chunk indexes → chunks),
/// as an indexed reader does: a file without a summary (not finished) is an error.
pub fn indexed_counts(path: &Path) -> Result<BTreeMap<String, u64>, String> {
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let summary = mcap::Summary::read(&bytes)
        .map_err(|e| e.to_string())?
        .ok_or("no summary section")?;
    if summary.chunk_indexes.is_empty() {
        return Err("no chunk index".into());
    }
    let mut c = BTreeMap::new();
    for index in &summary.chunk_indexes {
        for m in summary
            .stream_chunk(&bytes, index)
            .map_err(|e| e.to_string())?
        {
            let m = m.map_err(|e| e.to_string())?;
            *c.entry(m.channel.topic.clone()).or_insert(0) += 1;
        }
    }
    let total: u64 = c.values().sum();
    let stats = summary.stats.ok_or("no statistics")?;
    if stats.message_count != total {
        return Err(format!(
            "statistics say {} messages, the index gives {total}",
            stats.message_count
        ));
    }
    Ok(c)
}
