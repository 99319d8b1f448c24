// Checks serialised visualization_msgs/MarkerArray messages with an independent CDR
// implementation (@foxglove/rosmsg2-serialization, from the lockfile of tests/bag/fixtures):
// each input file is read with Jazzy's MarkerArray definition, written again by that library's
// own writer, and must come out byte for byte the same. Prints, per file, what was decoded
// (JSON), for marker_cdr_cross_check.py to compare with what the bridge meant to write.
//
//   node marker_cdr_check.mjs FILE...     (run from beside the npm packages' node_modules)
import { parse } from "@foxglove/rosmsg";
import { MessageReader, MessageWriter } from "@foxglove/rosmsg2-serialization";
import fs from "node:fs";

const SEP = "\n================================================================================\nMSG: ";
// Jazzy's visualization_msgs/msg/MarkerArray and every type it uses (fields only).
const definition = [
  "visualization_msgs/Marker[] markers",
  "visualization_msgs/Marker\nstd_msgs/Header header\nstring ns\nint32 id\nint32 type\n" +
    "int32 action\ngeometry_msgs/Pose pose\ngeometry_msgs/Vector3 scale\nstd_msgs/ColorRGBA color\n" +
    "builtin_interfaces/Duration lifetime\nbool frame_locked\ngeometry_msgs/Point[] points\n" +
    "std_msgs/ColorRGBA[] colors\nstring texture_resource\nsensor_msgs/CompressedImage texture\n" +
    "visualization_msgs/UVCoordinate[] uv_coordinates\nstring text\nstring mesh_resource\n" +
    "visualization_msgs/MeshFile mesh_file\nbool mesh_use_embedded_materials",
  "std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id",
  "builtin_interfaces/Time\nint32 sec\nuint32 nanosec",
  "builtin_interfaces/Duration\nint32 sec\nuint32 nanosec",
  "geometry_msgs/Pose\nPoint position\nQuaternion orientation",
  "geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z",
  "geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1",
  "geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z",
  "std_msgs/ColorRGBA\nfloat32 r\nfloat32 g\nfloat32 b\nfloat32 a",
  "sensor_msgs/CompressedImage\nstd_msgs/Header header\nstring format\nuint8[] data",
  "visualization_msgs/UVCoordinate\nfloat32 u\nfloat32 v",
  "visualization_msgs/MeshFile\nstring filename\nuint8[] data",
].join(SEP);
const parsed = parse(definition, { ros2: true });
const reader = new MessageReader(parsed);
const writer = new MessageWriter(parsed);

const results = [];
for (const file of process.argv.slice(2)) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  let message;
  try {
    message = reader.readMessage(bytes);
  } catch (error) {
    results.push({ file, error: `unreadable: ${error.message}` });
    continue;
  }
  const again = writer.writeMessage(message);
  const same = again.length === bytes.length && again.every((b, i) => b === bytes[i]);
  results.push({
    file,
    same_bytes: same,
    length: bytes.length,
    rewritten_length: again.length,
    markers: message.markers.map((m) => ({
      stamp: [m.header.stamp.sec, m.header.stamp.nanosec],
      frame_id: m.header.frame_id,
      ns: m.ns, id: m.id, type: m.type, action: m.action,
      orientation_w: m.pose.orientation.w,
      scale: [m.scale.x, m.scale.y, m.scale.z],
      points: m.points.map((p) => [p.x, p.y, p.z]),
      colors: m.colors.map((c) => [c.r, c.g, c.b, c.a]),
      strings: [m.texture_resource, m.texture.format, m.text, m.mesh_resource,
        m.mesh_file.filename],
    })),
  });
}
console.log(JSON.stringify(results));
