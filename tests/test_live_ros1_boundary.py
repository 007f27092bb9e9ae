"""The boundary of untrusted goals (issue 35) on the ROS 1 services that take a goal:
query_one, query_all, add_output_subscription and add_memory refuse each exploit with an error
reply, a query that catches its own time limit ends at the limit, and the node answers after.
The node and the master run as in tests/test_live_ros1.py (skipped where ROS 1 is absent)."""
from __future__ import annotations

from live_support import LIVE, retalisc_argv
from test_live_ros1 import _client, ros  # noqa: F401  (the module's master, as a fixture)


def test_ros1_services_refuse_goal_exploits_and_keep_answering(ros, tmp_path):  # noqa: F811
    python, env, processes = ros
    program = tmp_path / "tf_services.rtl"
    program.write_text((LIVE / "tf_services.rtl").read_text(encoding="utf-8")
                       + ":- rtl_set_flag(query_time_limit, 1).\n", encoding="utf-8")
    node = processes.start("boundary", retalisc_argv(python, "ros", str(program), "--config",
                                                     str(LIVE / "pub_sub.xml"), "--name", "iec_boundary"), env)
    canary = tmp_path / "pwned"
    try:
        processes.wait_for_line(node, "ros: node /iec_boundary")
        r = _client(python, env, "exploits", "iec_boundary", str(canary))
        assert node.poll() is None, processes.err("boundary")       # alive after every refusal
    finally:
        processes.stop(node)
    assert not canary.exists()
    for name in ("print_message", "format_W", "put_attr"):
        for service in ("query_all", "query_one", "add_output", "add_memory"):
            ok, error = r[f"{service}_{name}"]
            assert ok is False and "unsafe" in error, (service, name, error)
    for service in ("query_all", "query_one"):
        ok, error = r[f"{service}_thrown"]
        assert ok is False and "Unknown error term: format(" in error
        ok, error = r[f"{service}_aborted"]
        assert ok is False and "No permission to throw reserved_ball" in error
    ok, error = r["caught_limit"]
    assert ok is False and "time limit" in error and r["caught_limit_seconds"] < 10
    assert r["after"] == [True, ""]
