// A trace as a viewer opens it: `@mcap/core`'s indexed reader (the one Foxglove's app uses for
// local files) with @mcap/support's decompressors, every CRC checked (summary at open, each chunk
// as it is read, and the data section's here), and every message decoded with its channel's
// schema through protobufjs, as the app does.
//
//   node trace-check.mjs TRACE.mcap [TRACE.mcap ...]
//
// Per file: channels, schemas and per-topic counts, which must equal the file's Statistics
// record. Prints a final `RESULT {json}` line; exits 1 if a check failed.
import { McapIndexedReader } from "@mcap/core";
import { crc32 } from "@foxglove/crc";
import { loadDecompressHandlers, protobufFromBinaryDescriptor } from "@mcap/support";
import { open } from "node:fs/promises";

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error("usage: node trace-check.mjs TRACE.mcap [TRACE.mcap ...]");
  process.exit(2);
}

async function check(path, decompressHandlers) {
  const failures = [];
  const fail = (m) => failures.length < 20 && failures.push(m);
  const handle = await open(path, "r");
  try {
    const size = BigInt((await handle.stat()).size);
    const readable = {
      size: async () => size,
      read: async (offset, length) => {
        const buf = new Uint8Array(Number(length));
        const { bytesRead } = await handle.read(buf, 0, buf.length, Number(offset));
        if (bytesRead !== buf.length) throw new Error(`short read at ${offset}`);
        return buf;
      },
    };
    // Checks the summary CRC (and the footer, the index) as it opens.
    const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
    let dataCrc = "not written";
    if (reader.dataSectionCrc !== undefined) {
      const data = await readable.read(0n, reader.dataEndOffset);
      const crc = crc32(data);
      dataCrc = crc === reader.dataSectionCrc ? "valid" : "WRONG";
      if (crc !== reader.dataSectionCrc) fail(`data section CRC ${crc}, file says ${reader.dataSectionCrc}`);
    }
    const types = new Map(); // channel id -> protobufjs Type
    for (const [id, ch] of reader.channelsById) {
      const schema = reader.schemasById.get(ch.schemaId);
      if (!schema || schema.encoding !== "protobuf" || ch.messageEncoding !== "protobuf") {
        fail(`${ch.topic}: schema ${schema?.name} (${schema?.encoding}), messages ${ch.messageEncoding}`);
        continue;
      }
      try {
        types.set(id, protobufFromBinaryDescriptor(schema.data).lookupType(schema.name));
      } catch (e) {
        fail(`${ch.topic}: schema ${schema.name} does not load: ${e.message}`);
      }
    }
    const perTopic = new Map();
    let messages = 0;
    let foxglove = 0;
    let images = 0;
    for await (const m of reader.readMessages({ validateCrcs: true })) {
      messages++;
      const ch = reader.channelsById.get(m.channelId);
      const schemaName = reader.schemasById.get(ch.schemaId)?.name ?? "";
      const t = perTopic.get(ch.topic) ?? { schema: schemaName, messages: 0, decoded: 0 };
      perTopic.set(ch.topic, t);
      t.messages++;
      const type = types.get(m.channelId);
      if (!type) continue;
      let msg;
      try {
        msg = type.decode(m.data);
      } catch (e) {
        fail(`${ch.topic}: message ${m.sequence} does not decode as ${schemaName}: ${e.message}`);
        continue;
      }
      t.decoded++;
      if (schemaName.startsWith("foxglove.")) foxglove++;
      if (schemaName === "foxglove.RawImage") {
        if (msg.data.length !== msg.step * msg.height || msg.width === 0) {
          fail(`${ch.topic}: RawImage ${msg.width}x${msg.height}, step ${msg.step}, ${msg.data.length} bytes`);
        } else images++;
      }
    }
    const stats = reader.statistics;
    if (!stats) fail("no Statistics record");
    else {
      if (stats.messageCount !== BigInt(messages)) fail(`read ${messages} messages, Statistics says ${stats.messageCount}`);
      for (const [id, n] of stats.channelMessageCounts) {
        const topic = reader.channelsById.get(id)?.topic;
        const got = perTopic.get(topic)?.messages ?? 0;
        if (BigInt(got) !== n) fail(`${topic}: read ${got}, Statistics says ${n}`);
      }
    }
    const undecoded = [...perTopic].filter(([, t]) => t.decoded !== t.messages).map(([k]) => k);
    if (undecoded.length > 0) fail(`not every message decoded on ${undecoded.join(", ")}`);
    if (messages === 0) fail("no messages");
    return {
      file: path,
      channels: reader.channelsById.size,
      schemas: reader.schemasById.size,
      chunks: reader.chunkIndexes.length,
      messages,
      foxglove_decoded: foxglove,
      images,
      data_section_crc: dataCrc,
      topics: Object.fromEntries(perTopic),
      failures,
    };
  } finally {
    await handle.close();
  }
}

const decompressHandlers = await loadDecompressHandlers();
const results = [];
for (const f of files) {
  let r;
  try {
    r = await check(f, decompressHandlers);
  } catch (e) {
    r = { file: f, failures: [`does not open: ${e.message}`] };
  }
  results.push(r);
  if (r.messages !== undefined) {
    console.log(
      `${f}: ${r.channels} channels, ${r.schemas} schemas, ${r.chunks} chunks, ${r.messages} messages ` +
        `(${r.failures.length === 0 ? "= Statistics" : "see below"}), ${r.foxglove_decoded} foxglove.* messages decoded (${r.images} depth images), ` +
        `every other message decoded too; chunk and summary CRCs checked, data section CRC ${r.data_section_crc}`,
    );
  }
  for (const m of r.failures) console.error(`FAILED ${f}: ${m}`);
}
console.log(`RESULT ${JSON.stringify(results)}`);
if (results.some((r) => r.failures.length > 0)) process.exitCode = 1;
