// The live view as a viewer sees it: `@foxglove/ws-protocol`'s FoxgloveClient (what Lichtblick and
// the tools built on the library use) connects to `vpsom run --live` offering one subprotocol,
// subscribes to every channel, decodes every message with the schema it was advertised
// (protobufjs, through @mcap/support's descriptor loader, as Foxglove's app does), and compares
// what it received per topic with the recorder's own counts for the same interval.
//
//   node live-check.mjs --url ws://127.0.0.1:8765 --subprotocol foxglove.websocket.v1 \
//        [--seconds 120] [--require-all] [--min-intervals 2]
//
// --require-all: every channel the recorder wrote (by the last /recorder/stats received) must
// have reached the client; channels the run never writes are listed, not failed.
//
// Runs until the server closes the connection (the run ended) or --seconds pass. Prints one line
// per topic and a final `RESULT {json}` line; exits 1 if a check failed.
//
// The recorder's counts: the recorder publishes `/recorder/stats` (every topic's `written` count)
// every `recorder.stats_interval_s`, in order with everything it publishes, and right after each
// one it publishes again the messages it wrote once (`/truth/objects`, the latest `/nav/grid`) for
// viewers that connect later (runtime/src/recorder/writer.rs, `tick`). So between two stats
// messages A and B the client must receive, per topic, written(B) - written(A) messages, plus
// one re-sent message on those two topics if they had been written before A. The first stats
// message after subscribing is skipped (subscriptions take effect one by one).
import wsProtocol from "@foxglove/ws-protocol";
import { protobufFromBinaryDescriptor } from "@mcap/support";
import WebSocket from "ws";

// A CommonJS module: its named exports come through the default one.
const { FoxgloveClient } = wsProtocol;

const RESENT = ["/truth/objects", "/nav/grid"];
const STATS = "/recorder/stats";

function parseArgs(argv) {
  const a = { url: "", subprotocol: "", seconds: 120, requireAll: false, minIntervals: 1 };
  for (let i = 0; i < argv.length; i++) {
    const k = argv[i];
    const v = () => {
      if (i + 1 >= argv.length) throw new Error(`${k} needs a value`);
      return argv[++i];
    };
    if (k === "--url") a.url = v();
    else if (k === "--subprotocol") a.subprotocol = v();
    else if (k === "--seconds") a.seconds = Number(v());
    else if (k === "--min-intervals") a.minIntervals = Number(v());
    else if (k === "--require-all") a.requireAll = true;
    else throw new Error(`unknown argument ${k}`);
  }
  if (!a.url || !a.subprotocol) throw new Error("--url and --subprotocol are required");
  return a;
}

const args = parseArgs(process.argv.slice(2));
const failures = [];
const channels = new Map(); // channel id -> { topic, schemaName, type }
const subs = new Map(); // subscription id -> channel id
const perTopic = new Map(); // topic -> { schema, received, decoded }
const sinceStats = new Map(); // topic -> received since the last stats message
let statsSeen = 0;
let prevStats;
let lastStats;
const intervals = { compared: 0, equal: 0, mismatches: [] };
const checked = { rawImage: 0, sceneUpdate: 0, sceneEntities: 0 };
let decodeErrors = 0;

function fail(msg) {
  if (failures.length < 20) failures.push(msg);
}

function decoderFor(ch) {
  if (ch.encoding !== "protobuf" || ch.schemaEncoding !== "protobuf") {
    fail(`${ch.topic}: encoding ${ch.encoding}, schema encoding ${ch.schemaEncoding}`);
    return undefined;
  }
  try {
    const root = protobufFromBinaryDescriptor(Buffer.from(ch.schema, "base64"));
    return root.lookupType(ch.schemaName);
  } catch (e) {
    fail(`${ch.topic}: schema ${ch.schemaName} does not load: ${e.message}`);
    return undefined;
  }
}

// uint64 fields decode to Long objects (protobufjs with `long` installed).
const num = (x) => (typeof x === "object" && x !== null ? x.toNumber() : Number(x ?? 0));

function countsOf(stats) {
  return new Map(stats.topics.map((t) => [t.topic, num(t.written)]));
}

function compareInterval(a, b) {
  const wa = countsOf(a);
  const wb = countsOf(b);
  const bad = [];
  for (const [topic, after] of wb) {
    const before = wa.get(topic) ?? 0;
    const resent = RESENT.includes(topic) && before > 0 ? 1 : 0;
    const expected = after - before + resent;
    const got = sinceStats.get(topic) ?? 0;
    if (got !== expected) bad.push(`${topic}: received ${got}, recorder ${expected}`);
  }
  intervals.compared++;
  if (bad.length === 0) intervals.equal++;
  else if (intervals.mismatches.length < 5) intervals.mismatches.push(bad.join("; "));
}

function onMessage({ subscriptionId, data }) {
  const ch = channels.get(subs.get(subscriptionId));
  if (!ch) {
    fail(`message on unknown subscription ${subscriptionId}`);
    return;
  }
  const t = perTopic.get(ch.topic);
  t.received++;
  sinceStats.set(ch.topic, (sinceStats.get(ch.topic) ?? 0) + 1);
  if (!ch.type) return;
  let msg;
  try {
    msg = ch.type.decode(new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
  } catch (e) {
    decodeErrors++;
    fail(`${ch.topic}: a message does not decode as ${ch.schemaName}: ${e.message}`);
    return;
  }
  t.decoded++;
  if (ch.schemaName === "foxglove.RawImage") {
    const ok =
      msg.width > 0 &&
      msg.height > 0 &&
      msg.encoding === "16UC1" &&
      msg.step >= msg.width * 2 &&
      msg.data.length === msg.step * msg.height;
    if (ok) checked.rawImage++;
    else fail(`${ch.topic}: RawImage ${msg.width}x${msg.height} ${msg.encoding}, step ${msg.step}, ${msg.data.length} bytes`);
  } else if (ch.schemaName === "foxglove.SceneUpdate") {
    checked.sceneUpdate++;
    checked.sceneEntities += msg.entities.length;
  }
  if (ch.topic === STATS) {
    statsSeen++;
    lastStats = msg;
    if (statsSeen >= 3) compareInterval(prevStats, msg);
    // The second stats message starts the first interval (see the header).
    if (statsSeen >= 2) prevStats = msg;
    sinceStats.clear();
  }
}

const ws = new WebSocket(args.url, [args.subprotocol]);
const client = new FoxgloveClient({ ws });
let negotiated = "";
let closeReason = "";
const done = new Promise((resolve) => {
  const timer = setTimeout(() => {
    closeReason = `${args.seconds} s elapsed`;
    client.close();
    resolve();
  }, args.seconds * 1000);
  client.on("close", (ev) => {
    clearTimeout(timer);
    closeReason ||= `server closed (code ${ev?.code ?? "?"})`;
    resolve();
  });
  client.on("error", (e) => {
    fail(`client error: ${e?.message ?? e}`);
  });
});
client.on("open", () => {
  negotiated = ws.protocol;
});
client.on("serverInfo", (info) => {
  console.log(`server ${info.name}, capabilities [${info.capabilities.join(", ")}]`);
});
client.on("advertise", (chans) => {
  for (const ch of chans) {
    channels.set(ch.id, { ...ch, type: decoderFor(ch) });
    perTopic.set(ch.topic, { schema: ch.schemaName, received: 0, decoded: 0 });
    subs.set(client.subscribe(ch.id), ch.id);
  }
});
client.on("message", onMessage);
await done;

// Checks.
if (negotiated !== args.subprotocol) fail(`negotiated "${negotiated}", offered "${args.subprotocol}"`);
if (channels.size === 0) fail("no channel advertised");
const silent = [...perTopic].filter(([, t]) => t.received === 0).map(([topic]) => topic);
const written = lastStats ? countsOf(lastStats) : new Map();
const unwritten = [...perTopic.keys()].filter((topic) => !(written.get(topic) > 0));
const lost = silent.filter((topic) => !unwritten.includes(topic));
if (args.requireAll && !lastStats) fail("no /recorder/stats received");
if (args.requireAll && lost.length > 0) fail(`no message on ${lost.join(", ")}, which the recorder wrote`);
if (checked.rawImage === 0) fail("no foxglove.RawImage decoded");
if (checked.sceneUpdate === 0) fail("no foxglove.SceneUpdate decoded");
if (intervals.compared < args.minIntervals) fail(`${intervals.compared} stats intervals compared, wanted ${args.minIntervals}`);
for (const m of intervals.mismatches) fail(`interval: ${m}`);

console.log(`${args.subprotocol}: negotiated "${negotiated}", ${channels.size} channels, ended: ${closeReason}`);
console.log("topic                          schema                              received  decoded");
for (const [topic, t] of [...perTopic].sort()) {
  console.log(`${topic.padEnd(30)} ${t.schema.padEnd(35)} ${String(t.received).padStart(8)} ${String(t.decoded).padStart(8)}`);
}
console.log(
  `${perTopic.size - silent.length} of ${perTopic.size} channels received messages; ` +
    `the recorder wrote nothing on ${unwritten.length > 0 ? unwritten.join(", ") : "none"}`,
);
console.log(
  `intervals compared with /recorder/stats: ${intervals.compared}, equal ${intervals.equal}; ` +
    `RawImage checked ${checked.rawImage}, SceneUpdate ${checked.sceneUpdate} (${checked.sceneEntities} entities)`,
);
const result = {
  subprotocol: args.subprotocol,
  negotiated,
  channels: channels.size,
  topics: Object.fromEntries(perTopic),
  silent,
  unwritten,
  intervals,
  checked,
  decodeErrors,
  ended: closeReason,
  failures,
};
console.log(`RESULT ${JSON.stringify(result)}`);
if (failures.length > 0) {
  for (const f of failures) console.error(`FAILED: ${f}`);
  process.exitCode = 1;
}
