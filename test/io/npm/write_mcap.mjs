// Writes a small MCAP file with @mcap/core (the format's own JavaScript writer, from the npm registry), for
// test_mcap_reader: 50 std_msgs/String messages on /a and /b (every third on /b) in chunks of about 200 bytes,
// uncompressed, lz4 (lz4js) or zstd (Debian's zstd program). Usage: node write_mcap.mjs OUT.mcap [""|lz4|zstd]
import { McapWriter } from "@mcap/core";
import { execFileSync } from "node:child_process";
import fs from "node:fs";
import lz4 from "lz4js";

const [out, compression = ""] = process.argv.slice(2);
const fd = fs.openSync(out, "w");
let position = 0n;
const writable = {
  async write(buffer) {
    fs.writeSync(fd, buffer);
    position += BigInt(buffer.byteLength);
  },
  position: () => position,
};
const compressors = {
  lz4: (data) => ({ compression: "lz4", compressedData: lz4.compress(data) }),
  zstd: (data) => ({ compression: "zstd", compressedData: new Uint8Array(execFileSync("zstd", ["-q", "-c"], { input: data })) }),
};
const writer = new McapWriter({ writable, chunkSize: 200, compressChunk: compressors[compression] });
await writer.start({ profile: "ros2", library: "mcap-js test" });
const text = new TextEncoder();
const schemaId = await writer.registerSchema({ name: "std_msgs/msg/String", encoding: "ros2msg", data: text.encode("string data") });
const a = await writer.registerChannel({ schemaId, topic: "/a", messageEncoding: "cdr", metadata: new Map([["k", "v"]]) });
const b = await writer.registerChannel({ schemaId, topic: "/b", messageEncoding: "cdr", metadata: new Map() });
for (let i = 0; i < 50; ++i) {
  await writer.addMessage({ channelId: i % 3 === 0 ? b : a, sequence: i, logTime: BigInt(1000 + i), publishTime: BigInt(999 + i), data: text.encode("message " + i) });
}
await writer.end();
fs.closeSync(fd);
