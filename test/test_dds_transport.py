"""The project's processes discover each other on this host only, over UDP, without shared memory.

Fast DDS's shared-memory transport stalls a publisher for 333 ms when its port health check
catches a peer's listener between two signals (issue 18), so ``restrict_to_localhost`` gives
every process a UDP-only profile with the reach of ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

from conftest import spin_until

from safe_legged_c3bf.run.ros_domain import (
    PROFILE_VARIABLE,
    is_localhost_only,
    localhost_profile,
    restrict_to_localhost,
)

_NS = {"d": "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"}


def test_the_profile_and_system_default_range_are_chosen_for_fast_dds():
    env = {"ROS_LOCALHOST_ONLY": "1"}
    restrict_to_localhost(env)
    assert env == {PROFILE_VARIABLE: str(localhost_profile()),
                   "ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT"}
    again = dict(env)
    restrict_to_localhost(again)  # a child of a restricted process keeps the same
    assert again == env
    assert is_localhost_only(env)
    assert not is_localhost_only({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT"})
    assert not is_localhost_only({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"})


def test_a_users_profile_or_another_rmw_falls_back_to_the_localhost_range():
    for env in ({PROFILE_VARIABLE: "/etc/my_profile.xml"},
                {"RMW_IMPLEMENTATION": "rmw_cyclonedds_cpp"}):
        before = dict(env)
        restrict_to_localhost(env)
        assert env == {**before, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
        assert is_localhost_only(env)


def test_the_profile_is_udp_with_unicast_discovery_on_localhost_only():
    root = ET.parse(localhost_profile()).getroot()
    kinds = [t.findtext("d:type", namespaces=_NS)
             for t in root.iterfind(".//d:transport_descriptor", _NS)]
    assert kinds == ["UDPv4"]
    rtps = root.find(".//d:participant[@is_default_profile='true']/d:rtps", _NS)
    assert rtps.findtext("d:useBuiltinTransports", namespaces=_NS) == "false"
    peers = [a.text for a in rtps.iterfind("d:builtin/d:initialPeersList//d:address", _NS)]
    assert peers == ["127.0.0.1"]
    assert rtps.find("d:builtin/d:metatrafficUnicastLocatorList/d:locator", _NS) is not None
    assert rtps.find(".//d:metatrafficMulticastLocatorList", _NS) is None


_SHARED_MEMORY_MAPS = """
import rclpy
rclpy.init()
node = rclpy.create_node("shm_probe")
rclpy.spin_once(node, timeout_sec=0.5)
maps = open("/proc/self/maps").read()
print("shm_maps", sum("/dev/shm/fastrtps" in line for line in maps.splitlines()))
"""


def _shared_memory_maps(env: dict[str, str]) -> int:
    proc = subprocess.run([sys.executable, "-c", _SHARED_MEMORY_MAPS], env=env,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return int(proc.stdout.split("shm_maps", 1)[1].split()[0])


def test_a_process_of_the_session_maps_no_shared_memory_port():
    assert Path(os.environ[PROFILE_VARIABLE]) == localhost_profile()  # conftest restricted it
    assert _shared_memory_maps(dict(os.environ)) == 0
    localhost = {k: v for k, v in os.environ.items() if k != PROFILE_VARIABLE}
    localhost["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    assert _shared_memory_maps(localhost) > 0  # the check does see shared memory


_LOCALHOST_PONG = """
import rclpy, time
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node("pong")
pub = node.create_publisher(String, "/pong", 10)
node.create_subscription(String, "/ping", lambda m: pub.publish(String(data="pong " + m.data)), 10)
end = time.monotonic() + 30
while time.monotonic() < end:
    rclpy.spin_once(node, timeout_sec=0.1)
"""


def test_a_localhost_participant_with_shared_memory_talks_to_the_session(ros_executor):
    """E.g. a user's ``ros2 topic echo`` with ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST."""
    import rclpy
    from std_msgs.msg import String

    env = {k: v for k, v in os.environ.items() if k != PROFILE_VARIABLE}
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    pong = subprocess.Popen([sys.executable, "-c", _LOCALHOST_PONG], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        node = rclpy.create_node("ping", context=ros_executor.context_for_nodes)
        ros_executor.add_node(node)
        got = []
        node.create_subscription(String, "/pong", lambda m: got.append(m.data), 10)
        ping = node.create_publisher(String, "/ping", 10)

        def pinged() -> bool:
            if ping.get_subscription_count() and node.count_publishers("/pong"):
                ping.publish(String(data="1"))
            return bool(got)

        assert spin_until(ros_executor, pinged, timeout=20.0, step=0.1), "no reply over UDP"
        assert got[0] == "pong 1"
    finally:
        pong.kill()
        pong.wait(timeout=10)
