// Parser of the FSSCENE1 binary scene (GET /v1/sites/{id}/scene, GET /v1/jobs/{id}/scene).
//
//   bytes 0..7   "FSSCENE1"
//   bytes 8..11  uint32 LE H: header length (JSON, space-padded so that 12 + H is a multiple of 8)
//   12..12+H-1   header JSON {format, offset_m, arrays{name: {type, shape, offset, bytes}}, ...}
//   12+H..       data block; array `name` at 12 + H + offset (8-byte aligned)
//
// Returns {offset, buildingIds, materialNames, trajectories, header, arrays: {name: TypedArray}}; the typed
// arrays are views into the buffer (copies if unaligned). Positions stay relative to offset_m.

const MAGIC = 'FSSCENE1';
const TYPES = { f32: Float32Array, u32: Uint32Array, u16: Uint16Array, u8: Uint8Array };

export class SceneFormatError extends Error {}

function fail(msg) {
  throw new SceneFormatError('scene: ' + msg);
}

function readHeader(buf) {
  if (buf.byteLength < 12) fail('truncated (' + buf.byteLength + ' bytes)');
  const magic = new TextDecoder('ascii').decode(new Uint8Array(buf, 0, 8));
  if (magic !== MAGIC) fail('not a fragsim scene (magic "' + magic + '")');
  const h = new DataView(buf).getUint32(8, true);
  if (12 + h > buf.byteLength) fail('header length ' + h + ' beyond the end');
  const text = new TextDecoder('utf-8').decode(new Uint8Array(buf, 12, h));
  let header;
  try {
    header = JSON.parse(text);
  } catch (e) {
    fail('header is not JSON: ' + e.message);
  }
  if (header.format !== 'fragsim.scene/1') fail('unknown format "' + header.format + '"');
  return { header, dataStart: 12 + h };
}

function view(buf, dataStart, name, spec) {
  const Type = TYPES[spec.type];
  if (!Type) fail(`${name}: unknown type "${spec.type}"`);
  const rows = spec.shape[0], cols = spec.shape.length > 1 ? spec.shape[1] : 1;
  const count = rows * cols;
  if (spec.bytes !== count * Type.BYTES_PER_ELEMENT) fail(`${name}: ${spec.bytes} bytes for shape ${spec.shape}`);
  const start = dataStart + spec.offset;
  if (start + spec.bytes > buf.byteLength) fail(`${name}: beyond the end of the data`);
  if (start % Type.BYTES_PER_ELEMENT === 0) return new Type(buf, start, count);
  return new Type(buf.slice(start, start + spec.bytes));  // unaligned: copy
}

export function parseScene(buf) {
  const { header, dataStart } = readHeader(buf);
  const arrays = {};
  for (const [name, spec] of Object.entries(header.arrays || {})) arrays[name] = view(buf, dataStart, name, spec);
  if (!arrays.terrain_vertices || !arrays.terrain_triangles) fail('no terrain');
  return {
    header,
    offset: header.offset_m || [0, 0, 0],
    buildingIds: header.building_ids || [],
    materialNames: header.material_names || [],
    trajectories: header.trajectories || null,
    arrays,
  };
}
