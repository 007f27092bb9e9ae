// tf2::BufferCore (Debian's libtf2-dev) on a scenario of benchmarks/tf_lookup.py: the peer the
// tf library is measured against. Built by the benchmark:
//   g++ -O2 -o tf2_peer tf2_peer.cpp -ltf2 -lrostime -lconsole_bridge
// Input (standard input), one operation a line:
//   a PARENT CHILD STAMP_NS STATIC X Y Z QX QY QZ QW      a transform
//   l GROUP TARGET SOURCE STAMP_NS                        a lookup, timed per GROUP
// Output: one line per lookup (the pose, or "error"), then "cpu GROUP SECONDS COUNT" lines
// (ingest, then each group) and "heap BYTES" (malloc's bytes in use after minus before ingest).
#include <malloc.h>
#include <time.h>
#include <cstdio>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <geometry_msgs/TransformStamped.h>

static double cpu() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec + t.tv_nsec * 1e-9;
}

static ros::Time stamp(long long ns) {
  ros::Time t;
  t.fromNSec(static_cast<uint64_t>(ns));
  return t;
}

struct Lookup { std::string group, target, source; long long ns; };

int main() {
  std::ios::sync_with_stdio(false);
  std::vector<geometry_msgs::TransformStamped> transforms;
  std::vector<bool> statics;
  std::vector<Lookup> lookups;
  std::string line;
  while (std::getline(std::cin, line)) {
    std::istringstream in(line);
    char op;
    in >> op;
    if (op == 'a') {
      geometry_msgs::TransformStamped m;
      long long ns;
      int s;
      in >> m.header.frame_id >> m.child_frame_id >> ns >> s
         >> m.transform.translation.x >> m.transform.translation.y >> m.transform.translation.z
         >> m.transform.rotation.x >> m.transform.rotation.y >> m.transform.rotation.z >> m.transform.rotation.w;
      m.header.stamp = stamp(ns);
      transforms.push_back(m);
      statics.push_back(s != 0);
    } else if (op == 'l') {
      Lookup l;
      in >> l.group >> l.target >> l.source >> l.ns;
      lookups.push_back(l);
    }
  }
  size_t before = mallinfo2().uordblks;
  tf2::BufferCore buffer(ros::Duration(10.0));
  double t0 = cpu();
  for (size_t i = 0; i < transforms.size(); ++i)
    buffer.setTransform(transforms[i], "peer", statics[i]);
  double ingest = cpu() - t0;
  size_t heap = mallinfo2().uordblks - before;
  // each run of lookups of one group is timed as a whole; the answers are written after
  std::map<std::string, std::pair<double, int>> groups;
  std::vector<geometry_msgs::TransformStamped> found(lookups.size());
  std::vector<bool> ok(lookups.size(), false);
  for (size_t i = 0; i < lookups.size();) {
    size_t j = i;
    double s0 = cpu();
    for (; j < lookups.size() && lookups[j].group == lookups[i].group; ++j) {
      try {
        found[j] = buffer.lookupTransform(lookups[j].target, lookups[j].source, stamp(lookups[j].ns));
        ok[j] = true;
      } catch (const tf2::TransformException&) {
      }
    }
    groups[lookups[i].group].first += cpu() - s0;
    groups[lookups[i].group].second += static_cast<int>(j - i);
    i = j;
  }
  std::vector<std::string> lines;
  for (size_t i = 0; i < lookups.size(); ++i) {
    char text[256];
    const geometry_msgs::TransformStamped& r = found[i];
    if (ok[i])
      snprintf(text, sizeof text, "%.17g %.17g %.17g %.17g %.17g %.17g %.17g %llu",
               r.transform.translation.x, r.transform.translation.y, r.transform.translation.z,
               r.transform.rotation.x, r.transform.rotation.y, r.transform.rotation.z, r.transform.rotation.w,
               static_cast<unsigned long long>(r.header.stamp.toNSec()));
    else
      snprintf(text, sizeof text, "error");
    lines.push_back(text);
  }
  for (const std::string& s : lines) std::cout << s << "\n";
  std::cout << "cpu ingest " << ingest << " " << transforms.size() << "\n";
  for (const auto& g : groups) std::cout << "cpu " << g.first << " " << g.second.first << " " << g.second.second << "\n";
  std::cout << "heap " << heap << "\n";
  return 0;
}
