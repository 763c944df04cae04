// Writes ROS 2 messages as CDR with @foxglove/rosmsg2-serialization (an independent CDR writer, from the npm registry)
// and the message definitions of ROS 2 Humble (@foxglove/rosmsg-msgs-common), for test_ros2_cdr: OUT/<name>.cdr for
// sensor_msgs/PointCloud2, nav_msgs/Odometry, geometry_msgs/PoseStamped and tf2_msgs/TFMessage. Usage: node write_cdr.mjs OUT
import { MessageWriter } from "@foxglove/rosmsg2-serialization";
import common from "@foxglove/rosmsg-msgs-common";
import fs from "node:fs";

const out = process.argv[2];
const definitions = common.ros2humble;
/// The named definition first, then every complex type it uses.
function definitionsOf(name) {
  const list = [];
  const seen = new Set();
  const visit = (type) => {
    if (seen.has(type)) return;
    seen.add(type);
    list.push({ ...definitions[type], name: type });
    for (const field of definitions[type].definitions) if (field.isComplex) visit(field.type);
  };
  visit(name);
  return list;
}
const write = (file, type, message) => fs.writeFileSync(`${out}/${file}.cdr`, new MessageWriter(definitionsOf(type)).writeMessage(message));
const header = (sec, nanosec, frame_id) => ({ stamp: { sec, nanosec }, frame_id });
const pose = { position: { x: 1.5, y: -2.25, z: 3 }, orientation: { x: 0, y: 0, z: 0.6, w: 0.8 } };

// Three points of x, y, z and intensity (float32), ring (uint16) and t (uint32, ns after the stamp): 22 bytes each.
const cloud = new DataView(new ArrayBuffer(3 * 22));
[[1, 2, 3, 10, 0, 0], [4, 5, 6, 20, 1, 50000], [7, 8, 9, 30, 15, 99000]].forEach(([x, y, z, i, ring, t], k) => {
  const o = k * 22;
  cloud.setFloat32(o, x, true);
  cloud.setFloat32(o + 4, y, true);
  cloud.setFloat32(o + 8, z, true);
  cloud.setFloat32(o + 12, i, true);
  cloud.setUint16(o + 16, ring, true);
  cloud.setUint32(o + 18, t, true);
});
write("pointcloud2", "sensor_msgs/PointCloud2", {
  header: header(1700000000, 123456789, "os_sensor"),
  height: 1,
  width: 3,
  fields: [
    { name: "x", offset: 0, datatype: 7, count: 1 },
    { name: "y", offset: 4, datatype: 7, count: 1 },
    { name: "z", offset: 8, datatype: 7, count: 1 },
    { name: "intensity", offset: 12, datatype: 7, count: 1 },
    { name: "ring", offset: 16, datatype: 4, count: 1 },
    { name: "t", offset: 18, datatype: 6, count: 1 },
  ],
  is_bigendian: false,
  point_step: 22,
  row_step: 66,
  data: new Uint8Array(cloud.buffer),
  is_dense: true,
});
const covariance = Array.from({ length: 36 }, (_, i) => i / 10);
write("odometry", "nav_msgs/Odometry", {
  header: header(1700000001, 5000, "odom"),
  child_frame_id: "base_link",
  pose: { pose, covariance },
  twist: { twist: { linear: { x: 1, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0.1 } }, covariance },
});
write("pose_stamped", "geometry_msgs/PoseStamped", { header: header(1700000002, 7, "map"), pose });
write("tf_message", "tf2_msgs/TFMessage", {
  transforms: [
    { header: header(1700000003, 1, "odom"), child_frame_id: "base_link", transform: { translation: { x: 1, y: 2, z: 3 }, rotation: { x: 0, y: 0, z: 0, w: 1 } } },
    { header: header(1700000003, 2, "base_link"), child_frame_id: "os_sensor", transform: { translation: { x: 0.1, y: 0, z: 0.5 }, rotation: { x: 0, y: 0, z: 0.6, w: 0.8 } } },
  ],
});
