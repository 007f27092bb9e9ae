"""tf2's Python binding (Debian's python3-tf2, `tf2_py.BufferCore`) on a scenario of
benchmarks/tf_lookup.py (the format of tf2_peer.cpp): CPU seconds of the ingest and of each
group of lookups, as lines `cpu GROUP SECONDS COUNT`. Run with the system Python."""
import sys
import time

import rospy
import tf2_py
from geometry_msgs.msg import TransformStamped


def stamp(ns):
    return rospy.Time(ns // 1_000_000_000, ns % 1_000_000_000)


def main():
    adds, lookups = [], []
    for line in sys.stdin:
        f = line.split()
        if f and f[0] == "a":
            m = TransformStamped()
            m.header.frame_id, m.child_frame_id, m.header.stamp = f[1], f[2], stamp(int(f[3]))
            t, r = m.transform.translation, m.transform.rotation
            t.x, t.y, t.z, r.x, r.y, r.z, r.w = map(float, f[5:12])
            adds.append((m, f[4] == "1"))
        elif f and f[0] == "l":
            lookups.append((f[1], f[2], f[3], stamp(int(f[4]))))
    buffer = tf2_py.BufferCore(rospy.Duration(10))
    t0 = time.process_time()
    for m, static in adds:
        if static:
            buffer.set_transform_static(m, "peer")
        else:
            buffer.set_transform(m, "peer")
    print(f"cpu ingest {time.process_time() - t0} {len(adds)}")
    groups = {}
    for group, target, source, at in lookups:
        groups.setdefault(group, []).append((target, source, at))
    for group, items in groups.items():
        t0 = time.process_time()
        for target, source, at in items:
            try:
                buffer.lookup_transform_core(target, source, at)
            except tf2_py.TransformException:
                pass
        print(f"cpu {group} {time.process_time() - t0} {len(items)}")


if __name__ == "__main__":
    main()
