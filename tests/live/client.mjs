// Foxglove's own WebSocket client (@foxglove/ws-protocol) against `shoal run --live`: the test's
// independent viewer (tests/integration/test_live.py).
//
//   node tests/live/client.mjs ws://127.0.0.1:8765 [--topics a,b] [--slow MS]
//
// Subscribes to every advertised channel (or to --topics), decodes each message (JSON channels:
// parsed; any other encoding is reported, not decoded) and prints one JSON line per message:
// {"topic", "timestamp" (ns, a string), "encoding", "schemaName", "schemaEncoding", "message"}.
// First it prints {"advertised": [...channels]} once the server has advertised them. It exits 0
// when the server closes the connection (the run ended), 1 on an error. --slow MS: a viewer that
// takes MS ms over every message (its socket's buffers fill; the server must drop, not wait).
import pkg from "@foxglove/ws-protocol";
import WebSocket from "ws";

const { FoxgloveClient } = pkg;
const args = process.argv.slice(2);
const url = args[0];
const topicsAt = args.indexOf("--topics");
const wanted = topicsAt >= 0 ? new Set(args[topicsAt + 1].split(",")) : null;
const slowAt = args.indexOf("--slow");
const slowMs = slowAt >= 0 ? Number(args[slowAt + 1]) : 0;
const nap = new Int32Array(new SharedArrayBuffer(4)); // Atomics.wait: blocks without spinning

// foxglove-sdk 0.30's server answers "handshake failed" unless foxglove.sdk.v1 is offered too.
const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL, "foxglove.sdk.v1"]);
const client = new FoxgloveClient({ ws });
const channels = new Map(); // subscription id → channel
const text = new TextDecoder();
const out = (obj) => process.stdout.write(JSON.stringify(obj) + "\n");

client.on("advertise", (advertised) => {
  out({
    advertised: advertised.map((c) => ({
      topic: c.topic,
      encoding: c.encoding,
      schemaName: c.schemaName,
      schemaEncoding: c.schemaEncoding,
    })),
  });
  for (const c of advertised) {
    if (wanted === null || wanted.has(c.topic)) {
      channels.set(client.subscribe(c.id), c);
    }
  }
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const c = channels.get(subscriptionId);
  const line = {
    topic: c.topic,
    timestamp: timestamp.toString(),
    encoding: c.encoding,
    schemaName: c.schemaName,
    schemaEncoding: c.schemaEncoding,
  };
  if (c.encoding === "json") {
    line.message = JSON.parse(text.decode(data));
  } else {
    line.undecoded = data.byteLength;
  }
  out(line);
  if (slowMs > 0) {
    Atomics.wait(nap, 0, 0, slowMs);
  }
});
client.on("error", (error) => {
  process.stderr.write(`live client: ${error?.message ?? error}\n`);
  process.exitCode = 1;
});
client.on("close", () => {
  process.stdout.write("", () => process.exit(process.exitCode ?? 0));
});
