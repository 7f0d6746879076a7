//! Reading messages back through the schema stored in the file (`prost-reflect`): any channel to
//! JSON (the protobuf JSON mapping with proto field names, defaults included, 64-bit integers as
//! numbers, `bytes` as base64) and the types deriving `foxglove::Encode` and `Deserialize` (the
//! runtime's [`super::messages`], the app's own) back into Rust values.

use prost_reflect::{DescriptorPool, DynamicMessage, MessageDescriptor, SerializeOptions};
use serde::de::DeserializeOwned;

/// A channel's message type, from its schema record.
#[derive(Debug, Clone)]
pub struct MessageType(MessageDescriptor);

impl MessageType {
    /// The message type of a `protobuf` schema named `name` whose data is a `FileDescriptorSet`.
    pub fn from_schema(name: &str, encoding: &str, data: &[u8]) -> Result<Self, String> {
        if encoding != "protobuf" {
            return Err(format!(
                "schema {name} has encoding {encoding:?}, expected \"protobuf\""
            ));
        }
        let pool = DescriptorPool::decode(data)
            .map_err(|e| format!("schema {name}: not a FileDescriptorSet: {e}"))?;
        pool.get_message_by_name(name)
            .map(MessageType)
            .ok_or_else(|| format!("schema {name}: the descriptor set has no message {name}"))
    }

    /// Decode one message.
    pub fn decode(&self, data: &[u8]) -> Result<DynamicMessage, String> {
        DynamicMessage::decode(self.0.clone(), data)
            .map_err(|e| format!("{}: cannot decode: {e}", self.0.full_name()))
    }

    /// One message as JSON.
    pub fn to_json(&self, data: &[u8]) -> Result<serde_json::Value, String> {
        let m = self.decode(data)?;
        let opts = SerializeOptions::new()
            .use_proto_field_name(true)
            .skip_default_fields(false)
            .stringify_64_bit_integers(false)
            .use_enum_numbers(true);
        m.serialize_with_options(serde_json::value::Serializer, &opts)
            .map_err(|e| format!("{}: {e}", self.0.full_name()))
    }

    /// One message as a Rust value whose fields are named as the schema's (our own types).
    pub fn to_value<T: DeserializeOwned>(&self, data: &[u8]) -> Result<T, String> {
        serde_json::from_value(self.to_json(data)?)
            .map_err(|e| format!("{}: {e}", self.0.full_name()))
    }
}

#[cfg(test)]
mod tests {
    use super::super::messages::{DeadlineEvent, InputHealth, MetricValue, Metrics, NodeHealth};
    use super::*;
    use foxglove::Encode;

    fn roundtrip<T: Encode + DeserializeOwned>(v: &T) -> T {
        let s = T::get_schema().unwrap();
        let t = MessageType::from_schema(&s.name, &s.encoding, &s.data).unwrap();
        let mut buf = Vec::new();
        v.encode(&mut buf).unwrap();
        t.to_value(&buf).unwrap()
    }

    #[test]
    fn own_types_read_back_exactly() {
        let h = NodeHealth {
            seq: u64::MAX - 3,
            node: "mapper".into(),
            pid: 7,
            inputs: vec![
                InputHealth {
                    topic: "depth".into(),
                    received: 1 << 40,
                    invalid: 1,
                    ..Default::default()
                },
                InputHealth::default(),
            ],
            ..Default::default()
        };
        assert_eq!(roundtrip(&h), h);
        let e = DeadlineEvent {
            lateness_ns: -5,
            exec_ns: u64::MAX,
            miss: true,
            miss_cause: "exec".into(),
            ..Default::default()
        };
        assert_eq!(roundtrip(&e), e);
        let m = Metrics {
            values: vec![MetricValue {
                key: "a.b".into(),
                value: 0.1 + 0.2,
            }],
            json: "{}".into(),
        };
        assert_eq!(roundtrip(&m), m);
    }

    #[test]
    fn foxglove_schemas_decode_their_messages() {
        let img = foxglove::messages::RawImage {
            width: 2,
            height: 1,
            encoding: "16UC1".into(),
            data: foxglove::bytes::Bytes::from_static(&[1, 0, 2, 0]),
            ..Default::default()
        };
        let s = foxglove::messages::RawImage::get_schema().unwrap();
        assert_eq!(s.name, "foxglove.RawImage");
        let t = MessageType::from_schema(&s.name, &s.encoding, &s.data).unwrap();
        let mut buf = Vec::new();
        img.encode(&mut buf).unwrap();
        let v = t.to_json(&buf).unwrap();
        assert_eq!(v["encoding"], "16UC1");
        assert_eq!(v["data"], "AQACAA==");
        let e = MessageType::from_schema("x.Y", "jsonschema", b"{}").unwrap_err();
        assert!(e.contains("expected \"protobuf\""), "{e}");
    }
}
