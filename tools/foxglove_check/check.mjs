// Parse every channel and decode every message of an MCAP file the way Foxglove does.
//
//   node tools/foxglove_check/check.mjs RECORDING.mcap   -> one JSON object on stdout
//
// Reading: @mcap/core's McapStreamReader with @mcap/support's decompression handlers (zstd, lz4),
// the libraries Foxglove itself reads MCAP with. Parsing: the rules of Foxglove's published
// parser, packages/mcap-support/src/parseChannel.ts and parseProtobufSchema.ts of
// github.com/foxglove/studio (MPL-2.0), restated here for the encodings a recording of this bench
// can contain:
//   protobuf: schema encoding must be "protobuf"; FileDescriptorSet.decode(schema.data),
//     protobufjs.Root.fromDescriptor, resolveAll, lookupType(schema.name) (fully qualified),
//     messages decoded with type.toObject(type.decode(data), {defaults: true}); the datatypes
//     walk (protobufDefinitionsToDatatypes) accepts only the protobuf scalars it maps (double,
//     float, [su]int32/64, [s]fixed32/64, bool, string, bytes) and nested messages / enums.
//   json: schema encoding must be "jsonschema" (or no schema); every property must declare a
//     single type string, as Foxglove's parseJsonSchema throws "Unsupported type" otherwise.
// Anything else is reported as an error for that channel. Exit code 0 only if every channel
// parsed and every message decoded.
import fs from "node:fs";
import { McapStreamReader } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";
import protobufjs from "protobufjs";
import descriptor from "protobufjs/ext/descriptor/index.js";

const SCALARS = new Set(["double", "float", "int32", "sint32", "sfixed32", "uint32", "fixed32",
  "int64", "sint64", "sfixed64", "uint64", "fixed64", "bool", "string", "bytes"]);
const JSON_TYPES = new Set(["boolean", "string", "number", "integer", "object", "array"]);

function checkProtobufType(type, seen) {
  if (seen.has(type.fullName)) return;
  seen.add(type.fullName);
  for (const field of type.fieldsArray) {
    if (field.resolvedType instanceof protobufjs.Enum) continue;
    if (field.resolvedType) { checkProtobufType(field.resolvedType, seen); continue; }
    if (field.type === "bytes" && field.repeated) throw new Error("Repeated bytes are not currently supported");
    if (!SCALARS.has(field.type)) throw new Error(`Expected protobuf scalar type, got ${field.type}`);
  }
}

function parseChannel(channel, schema) {
  if (channel.messageEncoding === "protobuf") {
    if (schema?.encoding !== "protobuf") {
      throw new Error(`Message encoding protobuf with schema encoding '${schema?.encoding}' is not supported (expected protobuf)`);
    }
    const root = protobufjs.Root.fromDescriptor(descriptor.FileDescriptorSet.decode(schema.data));
    root.resolveAll();
    const type = root.lookupType(schema.name);
    checkProtobufType(type, new Set());
    if (type.fullName.replace(/^\./, "") !== schema.name) {
      throw new Error(`Protobuf schema does not contain an entry for '${schema.name}'`);
    }
    return {
      fields: type.fieldsArray.map((f) => [f.name, f.type]),
      deserialize: (data) => type.toObject(type.decode(data), { defaults: true }),
    };
  }
  if (channel.messageEncoding === "json") {
    if (schema != undefined && schema.encoding !== "jsonschema") {
      throw new Error(`Message encoding json with schema encoding '${schema.encoding}' is not supported`);
    }
    if (schema != undefined && schema.data.length > 0) {
      const js = JSON.parse(new TextDecoder().decode(schema.data));
      for (const [name, prop] of Object.entries(js.properties ?? {})) {
        if (typeof prop.type !== "string" || !JSON_TYPES.has(prop.type)) {
          throw new Error(`Unsupported type ${JSON.stringify(prop.type)} for field ${name}`);
        }
      }
    }
    return { fields: [], deserialize: (data) => JSON.parse(new TextDecoder().decode(data)) };
  }
  throw new Error(`Unsupported encoding ${channel.messageEncoding}`);
}

const path = process.argv[2];
const reader = new McapStreamReader({ decompressHandlers: await loadDecompressHandlers() });
reader.append(fs.readFileSync(path));
const schemas = new Map();
const channels = new Map();
const out = { file: path, channels: {}, errors: [] };
for (let rec; (rec = reader.nextRecord()) != undefined; ) {
  if (rec.type === "Schema") schemas.set(rec.id, rec);
  else if (rec.type === "Channel") {
    if (channels.has(rec.id)) continue;
    const schema = schemas.get(rec.schemaId);
    const entry = { topic: rec.topic, schema: schema?.name, messages: 0, sums: {}, fields: [] };
    try {
      const parsed = parseChannel(rec, schema);
      entry.fields = parsed.fields;
      channels.set(rec.id, { entry, parsed });
    } catch (err) {
      out.errors.push(`${rec.topic}: ${err.message}`);
      channels.set(rec.id, { entry, parsed: undefined });
    }
    out.channels[rec.topic] = entry;
  } else if (rec.type === "Message") {
    const ch = channels.get(rec.channelId);
    if (ch == undefined || ch.parsed == undefined) continue;
    try {
      const msg = ch.parsed.deserialize(rec.data);
      ch.entry.messages += 1;
      for (const [name, value] of Object.entries(msg)) {
        if (typeof value === "number" && Number.isFinite(value)) {
          ch.entry.sums[name] = (ch.entry.sums[name] ?? 0) + value;
        }
      }
    } catch (err) {
      out.errors.push(`${ch.entry.topic}: message ${rec.sequence}: ${err.message}`);
    }
  }
}
if (!reader.done()) out.errors.push("the file ends before its footer (truncated)");
process.stdout.write(JSON.stringify(out) + "\n");
process.exit(out.errors.length ? 1 : 0);
