"""tf2's BufferCore on a scenario of tests/tf_driver.pl, with the same output (run with the
system Python that has Debian's python3-tf2: `/usr/bin/python3 tests/tf2_oracle.py FILE`).

tf2's exceptions are read back into the tf library's reasons: `["unknown_frame", F]`,
`["not_connected", Target, Source]`, `["extrapolation", Direction, TimeNs, BoundNs]` (the
bound tf2's message names: the earliest data for the past, the latest for the future, the
only one for a single record)."""
import json
import re
import sys
from decimal import Decimal

import rospy
import tf2_py
from geometry_msgs.msg import TransformStamped

_PAST = re.compile(r"into the past\.\s+Requested time ([0-9.]+) but the earliest data is at time ([0-9.]+)")
_FUTURE = re.compile(r"into the future\.\s+Requested time ([0-9.]+) but the latest data is at time ([0-9.]+)")
_SINGLE = re.compile(r"extrapolation at time ([0-9.]+), but only time ([0-9.]+) is in the buffer")


def ns(text):
    return int(Decimal(text) * 1_000_000_000)


def stamp(n):
    return rospy.Time(n // 1_000_000_000, n % 1_000_000_000)


def reason(error):
    text = str(error)
    if isinstance(error, tf2_py.LookupException):
        return ["unknown_frame", re.match(r'"([^"]*)"', text).group(1)]
    if isinstance(error, tf2_py.ConnectivityException):
        found = re.search(r"between '([^']*)' and '([^']*)'", text)
        return ["not_connected", found.group(1), found.group(2)]
    if isinstance(error, tf2_py.ExtrapolationException):
        for pattern, direction in ((_PAST, "past"), (_FUTURE, "future")):
            found = pattern.search(text)
            if found:
                return ["extrapolation", direction, ns(found.group(1)), ns(found.group(2))]
        found = _SINGLE.search(text)
        if found:
            requested, only = ns(found.group(1)), ns(found.group(2))
            return ["extrapolation", "past" if requested < only else "future", requested, only]
    return ["other", type(error).__name__, text]


def message(parent, child, n, t, q):
    m = TransformStamped()
    m.header.frame_id, m.child_frame_id, m.header.stamp = parent, child, stamp(n)
    m.transform.translation.x, m.transform.translation.y, m.transform.translation.z = t
    r = m.transform.rotation
    r.x, r.y, r.z, r.w = q
    return m


def run(ops, out):
    buffer = tf2_py.BufferCore(rospy.Duration(10))
    for op in ops:
        kind = op[0]
        if kind == "buffer":
            buffer = tf2_py.BufferCore(rospy.Duration(op[1]))
        elif kind == "add":
            _, parent, child, n, t, q, static = op
            if static:
                buffer.set_transform_static(message(parent, child, n, t, q), "oracle")
            else:
                buffer.set_transform(message(parent, child, n, t, q), "oracle")
        elif kind == "lookup":
            _, target, source, n = op
            try:
                found = buffer.lookup_transform_core(target, source, stamp(n))
            except tf2_py.TransformException as error:
                out.write(json.dumps({"error": reason(error)}) + "\n")
                continue
            tr, r = found.transform.translation, found.transform.rotation
            s = found.header.stamp
            out.write(json.dumps({"pose": [tr.x, tr.y, tr.z, r.x, r.y, r.z, r.w],
                                  "stamp": s.secs * 1_000_000_000 + s.nsecs}) + "\n")
        elif kind == "can":
            _, target, source, n = op
            out.write(json.dumps({"can": bool(buffer.can_transform_core(target, source, stamp(n))[0])}) + "\n")


if __name__ == "__main__":
    with open(sys.argv[1]) as f:
        run(json.load(f)["ops"], sys.stdout)
