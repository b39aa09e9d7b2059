// Decode every message of an MCAP bag with Foxglove's JavaScript reader stack (@mcap/core with
// @mcap/support's decompressors, @foxglove/rosmsg to parse the ros2msg schemas,
// @foxglove/rosmsg2-serialization to decode CDR) and print, as JSON, the message count per topic
// and one field's time series: usage: node read_bag.mjs BAG.mcap TOPIC FIELD
import { open } from "node:fs/promises";
import { McapIndexedReader } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";

const [file, topic, field] = process.argv.slice(2);
if (!file || !topic || !field) {
  console.error("usage: node read_bag.mjs BAG.mcap TOPIC FIELD");
  process.exit(2);
}
const handle = await open(file, "r");
const { size } = await handle.stat();
const readable = {
  size: async () => BigInt(size),
  read: async (offset, length) => {
    const buffer = new Uint8Array(Number(length));
    await handle.read(buffer, 0, buffer.length, Number(offset));
    return buffer;
  },
};
const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers: await loadDecompressHandlers() });
const decoders = new Map();
for (const channel of reader.channelsById.values()) {
  const schema = reader.schemasById.get(channel.schemaId);
  if (schema.encoding !== "ros2msg" || channel.messageEncoding !== "cdr") {
    throw new Error(`${channel.topic}: ${schema.encoding}/${channel.messageEncoding} is not a ROS 2 channel`);
  }
  const definitions = parse(new TextDecoder().decode(schema.data), { ros2: true });
  decoders.set(channel.id, [channel.topic, new MessageReader(definitions)]);
}
const counts = {};
const series = { log_time: [], stamp: [], step: [], value: [] };
let decoded = 0;
for await (const message of reader.readMessages()) {
  const [name, decoder] = decoders.get(message.channelId);
  const value = decoder.readMessage(message.data);
  decoded += 1;
  counts[name] = (counts[name] ?? 0) + 1;
  if (name === topic) {
    series.log_time.push(Number(message.logTime));
    series.stamp.push(value.header.stamp.sec * 1e9 + value.header.stamp.nanosec);
    series.step.push(Number(value.step));
    series.value.push(value[field]);
  }
}
await handle.close();
console.log(JSON.stringify({ decoded, counts, series }));
