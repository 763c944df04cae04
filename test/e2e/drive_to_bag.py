#!/usr/bin/python3
"""Writes a ROS 1 bag from a loopd drive log (loopd-sim's lcm-logger file) with the ROS 1 Python tools (python3-rosbag,
Debian's packages; no ROS installation), for bag2lcm's tests and its speed figure.

Each LIDAR_SCAN becomes a sensor_msgs/PointCloud2 on /points (frame "lidar"), in a layout that cycles through those of
common drivers (--layouts mixed) or always the velodyne driver's (--layouts velodyne):
  velodyne  float32 x y z, intensity, uint16 ring [, float32 time]; point_step 32
  ouster    float32 x y z, intensity [, int32 t (ns)], uint16 reflectivity, uint8 ring; point_step 48; organised
            (2 rows) with a NaN cell after every 9th point and a NaN cell to fill the last row
  be64      float64 x y z and intensity, int32 laser_id [, float64 timestamp (s since the epoch)]; big-endian;
            point_step 44
  le64      float64 x y z, float32 intensity, int32 ring [, int32 offset_time (ns)]; point_step 32 (36 with times);
            2 rows, each padded with 8 bytes
The per-point times [in brackets] are written when the log's scans have them (point_cloud_t.time_offset), in each
layout's driver's unit; signed, since loopd-sim stamps the end of the sweep (times <= 0).
Each ODOMETRY_POSE (T_odom_lidar) becomes nav_msgs/Odometry on /odom (odom -> base_link) and a tf2_msgs/TFMessage on
/tf (odom -> base_link), with T_odom_base = T_odom_lidar * inv(T_base_lidar); /tf_static holds base_link -> mount ->
lidar (T_base_lidar = T_base_mount * T_mount_lidar, printed by --print-extrinsic). Each GROUND_TRUTH_POSE becomes a
geometry_msgs/PoseStamped of base_link on /ground_truth. /tf also carries base_link -> wheel, which no pose needs. Each IMU
sample (imu_t, in the lidar's frame) becomes a sensor_msgs/Imu on /imu in frame "imu", mounted upside down and turned
on base_link (/tf_static base_link -> imu), its turn rate and specific force turned into that frame.
Bag times are the log's event times. With --bad-messages the bag also holds, between scans, one PointCloud2 without
an x field, one Odometry with a zero quaternion and one /tf message with a NaN translation. --corrupt-index COPY also
writes a copy of the bag with a damaged index entry (rosbag_storage then reads outside its buffer).

The log is read with the struct module (lcm-logger events, then point_cloud_t and pose_t as lcm-gen encodes them:
big-endian, after an 8-byte fingerprint). Usage: drive_to_bag.py DRIVE.lcmlog OUT.bag [options]
"""
import argparse
import array
import math
import struct
import sys

import rosbag
import rospy
from geometry_msgs.msg import PoseStamped, TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Imu, PointCloud2, PointField
from tf2_msgs.msg import TFMessage

SYNC = 0xEDA1DA01
FLOAT32, UINT8, UINT16, INT32, FLOAT64 = PointField.FLOAT32, PointField.UINT8, PointField.UINT16, PointField.INT32, PointField.FLOAT64


def read_log(path):
    """Yields (timestamp, channel, data) of each event of an lcm-logger file."""
    with open(path, 'rb') as f:
        blob = f.read()
    pos = 0
    while pos + 28 <= len(blob):
        sync, _, timestamp, channel_len, data_len = struct.unpack_from('>IqqiI', blob, pos)
        if sync != SYNC:
            raise SystemExit('drive_to_bag: bad sync word at byte %d of %s' % (pos, path))
        pos += 28
        channel = blob[pos:pos + channel_len].decode()
        pos += channel_len
        yield timestamp, channel, blob[pos:pos + data_len]
        pos += data_len


def floats(data, pos, n):
    a = array.array('f')
    a.frombytes(data[pos:pos + 4 * n])
    if sys.byteorder == 'little':
        a.byteswap()
    return a, pos + 4 * n


def decode_cloud(data):
    pos = 8
    utime, seq, frame_len = struct.unpack_from('>qqi', data, pos)
    pos += 20
    frame = data[pos:pos + frame_len - 1].decode()
    pos += frame_len
    (n,) = struct.unpack_from('>i', data, pos)
    pos += 4
    x, pos = floats(data, pos, n)
    y, pos = floats(data, pos, n)
    z, pos = floats(data, pos, n)
    intensity, pos = floats(data, pos, n)
    (m,) = struct.unpack_from('>i', data, pos)
    pos += 4
    ring = array.array('h')
    ring.frombytes(data[pos:pos + 2 * m])
    if sys.byteorder == 'little':
        ring.byteswap()
    pos += 2 * m
    (num_rings,) = struct.unpack_from('>h', data, pos)
    pos += 2
    time = array.array('f')
    if pos + 4 <= len(data):  # point_cloud_t with per-point times (num_point_times, time_offset)
        (k,) = struct.unpack_from('>i', data, pos)
        time, pos = floats(data, pos + 4, k)
    return dict(utime=utime, seq=seq, frame=frame, x=x, y=y, z=z, intensity=intensity, ring=ring, num_rings=num_rings, time=time)


def decode_pose(data):
    utime, seq, px, py, pz, qw, qx, qy, qz = struct.unpack_from('>qq7d', data, 8)
    return dict(utime=utime, seq=seq, t=(px, py, pz), q=(qw, qx, qy, qz))


# Poses as (translation, quaternion w x y z).
def quat_mul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


def rotate(q, v):
    w, x, y, z = quat_mul(quat_mul(q, (0.0,) + tuple(v)), (q[0], -q[1], -q[2], -q[3]))
    return (x, y, z)


def compose(a, b):
    t = rotate(a[1], b[0])
    return ((a[0][0] + t[0], a[0][1] + t[1], a[0][2] + t[2]), quat_mul(a[1], b[1]))


def inverse(a):
    qi = (a[1][0], -a[1][1], -a[1][2], -a[1][3])
    t = rotate(qi, a[0])
    return ((-t[0], -t[1], -t[2]), qi)


def rpy_quat(roll, pitch, yaw):
    cr, sr, cp, sp, cy, sy = math.cos(roll / 2), math.sin(roll / 2), math.cos(pitch / 2), math.sin(pitch / 2), math.cos(yaw / 2), math.sin(yaw / 2)
    return (cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy)


T_BASE_MOUNT = ((0.5, 0.0, 1.2), rpy_quat(0.0, 0.0, math.radians(90.0)))
T_MOUNT_LIDAR = ((0.1, 0.05, 0.3), rpy_quat(math.radians(2.0), math.radians(-3.0), math.radians(10.0)))
T_BASE_LIDAR = compose(T_BASE_MOUNT, T_MOUNT_LIDAR)
T_BASE_IMU = ((0.2, -0.1, 0.4), rpy_quat(math.radians(180.0), 0.0, math.radians(-30.0)))  # upside down, turned


def stamp(utime):
    return rospy.Time(utime // 1000000, (utime % 1000000) * 1000)


def set_pose(msg_pose, T):
    msg_pose.position.x, msg_pose.position.y, msg_pose.position.z = T[0]
    msg_pose.orientation.w, msg_pose.orientation.x, msg_pose.orientation.y, msg_pose.orientation.z = T[1]


def transform(parent, child, utime, T, seq=0):
    t = TransformStamped()
    t.header.stamp, t.header.frame_id, t.header.seq, t.child_frame_id = stamp(utime), parent, seq, child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = T[0]
    t.transform.rotation.w, t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z = T[1]
    return t


def as_bytes(values, typecode, big_endian=False):
    a = array.array(typecode, values)
    if big_endian != (sys.byteorder == 'big'):
        a.byteswap()
    return a.tobytes()


def interleave(n_cells, step, columns, row_padding=0, rows=1):
    """Point data: columns = [(offset, bytes of all cells, value size)], rows of n_cells / rows cells, padded rows."""
    data = bytearray(n_cells * step)
    for offset, raw, size in columns:
        for k in range(size):
            data[offset + k::step] = raw[k::size]
    if not row_padding:
        return bytes(data)
    width = n_cells // rows
    out = bytearray()
    for r in range(rows):
        out += data[r * width * step:(r + 1) * width * step] + b'\xcd' * row_padding
    return bytes(out)


def cloud_message(scan, layout):
    n = len(scan['x'])
    ring = list(scan['ring']) if len(scan['ring']) == n else [0] * n
    msg = PointCloud2()
    msg.header.stamp, msg.header.frame_id, msg.header.seq = stamp(scan['utime']), scan['frame'], scan['seq']
    msg.height, msg.is_dense, msg.is_bigendian = 1, True, False
    x, y, z, inten = scan['x'], scan['y'], scan['z'], scan['intensity']
    times = list(scan['time']) if len(scan['time']) == n else None
    if layout == 'velodyne':
        msg.point_step, msg.width = 32, n
        cols = [(0, as_bytes(x, 'f'), 4), (4, as_bytes(y, 'f'), 4), (8, as_bytes(z, 'f'), 4), (16, as_bytes(inten, 'f'), 4),
                (20, as_bytes(ring, 'H'), 2)]
        msg.fields = [PointField('x', 0, FLOAT32, 1), PointField('y', 4, FLOAT32, 1), PointField('z', 8, FLOAT32, 1),
                      PointField('intensity', 16, FLOAT32, 1), PointField('ring', 20, UINT16, 1)]
        if times:
            cols.append((24, as_bytes(times, 'f'), 4))
            msg.fields.append(PointField('time', 24, FLOAT32, 1))
        msg.data = interleave(n, 32, cols)
    elif layout == 'ouster':
        nan = float('nan')
        cells = []
        for i in range(n):
            cells.append(i)
            if i % 9 == 8:
                cells.append(-1)
        if len(cells) % 2:
            cells.append(-1)
        pick = lambda a, fill: [a[c] if c >= 0 else fill for c in cells]
        m = len(cells)
        msg.point_step, msg.height, msg.width, msg.is_dense = 48, 2, m // 2, False
        cols = [(0, as_bytes(pick(x, nan), 'f'), 4), (4, as_bytes(pick(y, nan), 'f'), 4), (8, as_bytes(pick(z, nan), 'f'), 4),
                (16, as_bytes(pick(inten, 0.0), 'f'), 4), (24, as_bytes([7] * m, 'H'), 2), (26, as_bytes(pick(ring, 0), 'B'), 1)]
        msg.fields = [PointField('x', 0, FLOAT32, 1), PointField('y', 4, FLOAT32, 1), PointField('z', 8, FLOAT32, 1),
                      PointField('intensity', 16, FLOAT32, 1), PointField('reflectivity', 24, UINT16, 1), PointField('ring', 26, UINT8, 1)]
        if times:  # nanoseconds as Ouster's t, but signed: loopd-sim stamps the end of the sweep, so times are <= 0
            cols.append((20, as_bytes(pick([round(t * 1e9) for t in times], 0), 'i'), 4))
            msg.fields.append(PointField('t', 20, INT32, 1))
        msg.data = interleave(m, 48, cols)
    elif layout == 'be64':
        msg.width, msg.is_bigendian = n, True
        msg.point_step = 44
        cols = [(0, as_bytes(x, 'd', True), 8), (8, as_bytes(y, 'd', True), 8), (16, as_bytes(z, 'd', True), 8), (24, as_bytes(inten, 'd', True), 8),
                (32, as_bytes(ring, 'i', True), 4)]
        msg.fields = [PointField('x', 0, FLOAT64, 1), PointField('y', 8, FLOAT64, 1), PointField('z', 16, FLOAT64, 1),
                      PointField('intensity', 24, FLOAT64, 1), PointField('laser_id', 32, INT32, 1)]
        if times:  # seconds since the epoch, as Hesai's timestamp
            t0 = scan['utime'] // 1000000 + (scan['utime'] % 1000000) * 1e-6
            cols.append((36, as_bytes([t0 + t for t in times], 'd', True), 8))
            msg.fields.append(PointField('timestamp', 36, FLOAT64, 1))
        msg.data = interleave(n, 44, cols)
    else:  # le64: two rows with padding after each
        rows = 2 if n % 2 == 0 else 1
        msg.point_step, msg.height, msg.width = 32, rows, n // rows
        cols = [(0, as_bytes(x, 'd'), 8), (8, as_bytes(y, 'd'), 8), (16, as_bytes(z, 'd'), 8), (24, as_bytes(inten, 'f'), 4), (28, as_bytes(ring, 'i'), 4)]
        msg.fields = [PointField('x', 0, FLOAT64, 1), PointField('y', 8, FLOAT64, 1), PointField('z', 16, FLOAT64, 1),
                      PointField('intensity', 24, FLOAT32, 1), PointField('ring', 28, INT32, 1)]
        if times:  # nanoseconds as Livox's offset_time, but signed (see ouster)
            msg.point_step = 36
            cols.append((32, as_bytes([round(t * 1e9) for t in times], 'i'), 4))
            msg.fields.append(PointField('offset_time', 32, INT32, 1))
        msg.data = interleave(n, msg.point_step, cols, row_padding=8, rows=rows)
    msg.row_step = msg.width * msg.point_step + (8 if layout == 'le64' else 0)
    return msg


def write_static(bag, utime):
    msg = TFMessage(transforms=[transform('base_link', 'mount', utime, T_BASE_MOUNT), transform('mount', 'lidar', utime, T_MOUNT_LIDAR),
                                transform('base_link', 'imu', utime, T_BASE_IMU)])
    bag.write('/tf_static', msg, stamp(utime))


def write_pose(bag, ev_time, channel, pose):
    T_base = compose((pose['t'], pose['q']), inverse(T_BASE_LIDAR))
    if channel == 'ODOMETRY_POSE':
        odom = Odometry()
        odom.header.stamp, odom.header.frame_id, odom.header.seq, odom.child_frame_id = stamp(pose['utime']), 'odom', pose['seq'], 'base_link'
        set_pose(odom.pose.pose, T_base)
        bag.write('/odom', odom, stamp(ev_time))
        tf = TFMessage(transforms=[transform('odom', 'base_link', pose['utime'], T_base, pose['seq'])])
        bag.write('/tf', tf, stamp(ev_time))
        wheel = TFMessage(transforms=[transform('base_link', 'wheel', pose['utime'] + 1000, ((0.0, 0.8, 0.3), rpy_quat(0.0, 0.1 * pose['seq'], 0.0)))])
        bag.write('/tf', wheel, stamp(ev_time + 1000))
    elif channel == 'GROUND_TRUTH_POSE':
        gt = PoseStamped()
        gt.header.stamp, gt.header.frame_id, gt.header.seq = stamp(pose['utime']), 'map', pose['seq']
        set_pose(gt.pose, T_base)
        bag.write('/ground_truth', gt, stamp(ev_time))


def write_imu(bag, ev_time, data):
    utime, seq = struct.unpack_from('>qq', data, 8)
    w = struct.unpack_from('>3d', data, 24)
    f = struct.unpack_from('>3d', data, 48)
    q_imu_lidar = inverse(T_BASE_IMU)[1]
    q_imu_lidar = quat_mul(q_imu_lidar, T_BASE_LIDAR[1])
    msg = Imu()
    msg.header.stamp, msg.header.frame_id, msg.header.seq = stamp(utime), 'imu', seq & 0xFFFFFFFF
    msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z = rotate(q_imu_lidar, w)
    msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z = rotate(q_imu_lidar, f)
    msg.orientation_covariance[0] = -1.0  # no orientation
    bag.write('/imu', msg, stamp(ev_time))


def write_bad_messages(bag, utime):
    cloud = PointCloud2()
    cloud.header.stamp, cloud.header.frame_id = stamp(utime), 'lidar'
    cloud.height, cloud.width, cloud.point_step, cloud.row_step = 1, 2, 8, 16
    cloud.fields = [PointField('y', 0, FLOAT32, 1), PointField('z', 4, FLOAT32, 1)]
    cloud.data = bytes(16)
    bag.write('/points', cloud, stamp(utime))
    odom = Odometry()
    odom.header.stamp, odom.header.frame_id, odom.child_frame_id = stamp(utime), 'odom', 'base_link'
    bag.write('/odom', odom, stamp(utime))  # orientation (0, 0, 0, 0)
    bad = transform('odom', 'base_link', utime, ((float('nan'), 0.0, 0.0), (1.0, 0.0, 0.0, 0.0)))
    bag.write('/tf', TFMessage(transforms=[bad]), stamp(utime))


def corrupt_index(bag_path, out_path):
    """A copy of the bag whose first index entry points 1 GiB past its chunk: rosbag_storage reads there unchecked."""
    with open(bag_path, 'rb') as f:
        b = bytearray(f.read())
    op = b.find(b'op=\x04')  # the first IndexData record's header field
    for start in range(max(0, op - 200), op):  # its header: u32 length, then fields of u32 length + name=value
        header_len = struct.unpack_from('<I', b, start)[0]
        if not start + 4 <= op < start + 4 + header_len or header_len > 200:
            continue
        pos, names = start + 4, []
        while pos + 4 <= start + 4 + header_len:
            field_len = struct.unpack_from('<I', b, pos)[0]
            names.append(bytes(b[pos + 4:pos + 4 + field_len]).split(b'=')[0])
            pos += 4 + field_len
        if pos == start + 4 + header_len and b'op' in names and b'count' in names:
            data = start + 4 + header_len  # u32 data length, then entries: u32 sec, u32 nsec, u32 offset
            struct.pack_into('<I', b, data + 4 + 8, 0x40000000)
            with open(out_path, 'wb') as f:
                f.write(b)
            return
    raise SystemExit('drive_to_bag: no IndexData record found in ' + bag_path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('drive')
    ap.add_argument('out')
    ap.add_argument('--compression', default='none', choices=['none', 'bz2', 'lz4'])
    ap.add_argument('--layouts', default='mixed', choices=['mixed', 'velodyne'])
    ap.add_argument('--bad-messages', action='store_true')
    ap.add_argument('--print-extrinsic', action='store_true', help='print T_base_lidar (x y z qw qx qy qz) and exit')
    ap.add_argument('--corrupt-index', metavar='COPY', help='also write a copy whose first index entry points far outside its chunk')
    args = ap.parse_args()
    if args.print_extrinsic:
        print(' '.join('%.17g' % v for v in T_BASE_LIDAR[0] + T_BASE_LIDAR[1]))
        return
    layouts = ['velodyne', 'ouster', 'be64', 'le64'] if args.layouts == 'mixed' else ['velodyne']
    scans = 0
    static_written = False
    with rosbag.Bag(args.out, 'w', compression=args.compression) as bag:
        for ev_time, channel, data in read_log(args.drive):
            if not static_written:
                write_static(bag, ev_time)
                static_written = True
            if channel == 'LIDAR_SCAN':
                bag.write('/points', cloud_message(decode_cloud(data), layouts[scans % len(layouts)]), stamp(ev_time))
                scans += 1
                if args.bad_messages and scans == 3:
                    write_bad_messages(bag, ev_time + 50000)
            elif channel in ('ODOMETRY_POSE', 'GROUND_TRUTH_POSE'):
                write_pose(bag, ev_time, channel, decode_pose(data))
            elif channel == 'IMU':
                write_imu(bag, ev_time, data)
    if args.corrupt_index:
        corrupt_index(args.out, args.corrupt_index)
    print('drive_to_bag: %d scans -> %s' % (scans, args.out))


if __name__ == '__main__':
    main()
