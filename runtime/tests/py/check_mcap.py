#!/usr/bin/env python3
"""Independent check of a vpsom-rt MCAP trace.

Reads FILE with the `mcap` package with CRC validation on, decodes every message with the
`mcap-protobuf-support` decoder (protobuf, through the FileDescriptorSet in the file), checks
that every `foxglove.*` schema is Foxglove's own protobuf schema (its fields agree, by name,
number, type and label, with the precompiled `foxglove-schemas-protobuf` package), and prints
the message count per topic as one JSON object on stdout.

  check_mcap.py FILE [--expect-topic TOPIC=N ...]

Exits non-zero on a CRC error, a channel that is not protobuf, an undecodable message, a
foxglove schema that differs from Foxglove's, or a count that differs from an --expect-topic
value (topics not named are not checked).
Needs: pip install mcap mcap-protobuf-support foxglove-schemas-protobuf
"""
import argparse
import importlib
import json
import sys

from google.protobuf import descriptor_pb2
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory


def fields(desc: descriptor_pb2.DescriptorProto) -> dict:
    return {f.name: (f.number, f.type, f.label, f.type_name.lstrip(".")) for f in desc.field}


def reference_fields(name: str) -> dict:
    """Fields of Foxglove's own message `name` (e.g. foxglove.RawImage)."""
    short = name.split(".", 1)[1]
    mod = importlib.import_module(f"foxglove_schemas_protobuf.{short}_pb2")
    proto = descriptor_pb2.DescriptorProto()
    getattr(mod, short).DESCRIPTOR.CopyToProto(proto)
    return fields(proto)


def file_fields(name: str, data: bytes) -> dict:
    fds = descriptor_pb2.FileDescriptorSet.FromString(data)
    short = name.split(".", 1)[1]
    for f in fds.file:
        if f.package == "foxglove":
            for m in f.message_type:
                if m.name == short:
                    return fields(m)
    raise KeyError(f"{name} not in its FileDescriptorSet")


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("file")
    ap.add_argument("--expect-topic", action="append", default=[], metavar="TOPIC=N")
    args = ap.parse_args()

    counts = {}
    checked = {}
    with open(args.file, "rb") as f:
        reader = make_reader(f, validate_crcs=True, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        if summary is None:
            print(f"{args.file}: no summary section (file not finished)", file=sys.stderr)
            return 1
        for schema, channel, message, decoded in reader.iter_decoded_messages(
            log_time_order=False
        ):
            if channel.message_encoding != "protobuf":
                print(f"{channel.topic}: unexpected encoding {channel.message_encoding}",
                      file=sys.stderr)
                return 1
            if schema is None or schema.encoding != "protobuf":
                print(f"{channel.topic}: needs a protobuf schema", file=sys.stderr)
                return 1
            if schema.name.startswith("foxglove.") and schema.id not in checked:
                ours, ref = file_fields(schema.name, schema.data), reference_fields(schema.name)
                if ours != ref:
                    print(f"{channel.topic}: {schema.name} differs from Foxglove's: "
                          f"file {ours} vs foxglove-schemas-protobuf {ref}", file=sys.stderr)
                    return 1
                checked[schema.id] = schema.name
            if decoded is None or type(decoded).__name__ != schema.name.split(".")[-1]:
                print(f"{channel.topic} seq {message.sequence}: not decoded as {schema.name}",
                      file=sys.stderr)
                return 1
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
        # Statistics in the summary must agree with what was read.
        if summary.statistics is not None:
            total = sum(counts.values())
            if summary.statistics.message_count != total:
                print(f"statistics say {summary.statistics.message_count} messages, read {total}",
                      file=sys.stderr)
                return 1

    print(json.dumps(counts, sort_keys=True))
    failed = False
    for e in args.expect_topic:
        topic, _, n = e.rpartition("=")
        if counts.get(topic, 0) != int(n):
            print(f"{topic}: expected {n} messages, read {counts.get(topic, 0)}", file=sys.stderr)
            failed = True
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
