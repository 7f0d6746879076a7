#!/usr/bin/env python3
"""Independent check of a vpsom-rt MCAP trace.

Reads FILE with the `mcap` package with CRC validation on, decodes every message
(json -> json.loads, then validated against its channel's JSON Schema with `jsonschema`),
and prints the message count per topic as one JSON object on stdout.

  check_mcap.py FILE [--expect-topic TOPIC=N ...]

Exits non-zero on a CRC error, an undecodable message, a schema violation, or a count that
differs from an --expect-topic value (topics not named are not checked).
Needs: pip install mcap jsonschema
"""
import argparse
import json
import sys

import jsonschema
from mcap.reader import make_reader


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("file")
    ap.add_argument("--expect-topic", action="append", default=[], metavar="TOPIC=N")
    args = ap.parse_args()

    counts = {}
    validators = {}
    with open(args.file, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        if summary is None:
            print(f"{args.file}: no summary section (file not finished)", file=sys.stderr)
            return 1
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if channel.message_encoding != "json":
                print(f"{channel.topic}: unexpected encoding {channel.message_encoding}",
                      file=sys.stderr)
                return 1
            if schema is None or schema.encoding != "jsonschema":
                print(f"{channel.topic}: needs a jsonschema schema", file=sys.stderr)
                return 1
            v = validators.get(schema.id)
            if v is None:
                s = json.loads(schema.data)
                jsonschema.Draft202012Validator.check_schema(s)
                v = jsonschema.Draft202012Validator(s)
                validators[schema.id] = v
            try:
                value = json.loads(message.data)
                v.validate(value)
            except Exception as e:  # noqa: BLE001 - report any decode/validation failure
                print(f"{channel.topic} seq {message.sequence}: {e}", file=sys.stderr)
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
