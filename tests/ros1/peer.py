"""A ROS 1 node for the intrusion tests: `peer.py NAME publisher|subscriber TOPIC`
publishes geometry_msgs/Twist at 20 Hz on TOPIC, or subscribes to it, until
SIGINT or SIGTERM; `peer.py NAME quiet TOPIC` advertises TwistStamped on it and
sends nothing (the soak's publishers that come and go); `peer.py NAME sneak TOPIC
SUBSCRIBER` advertises TOPIC, unregisters it from the master, and hands its address
straight to SUBSCRIBER (its `publisherUpdate`), which connects though the master
never says so."""

from __future__ import annotations

import signal
import threading

# First of all: a stop asked while the node still starts (a loaded machine takes
# seconds to import rospy and register) is honoured once it has started, with the
# clean shutdown that unregisters it. Python's own SIGINT, mid-start, left the
# master listing a node that was gone (the intrusion node rightly called it stale).
STOP = threading.Event()
for _number in (signal.SIGINT, signal.SIGTERM):
    signal.signal(_number, lambda *_: STOP.set())

import faulthandler  # noqa: E402

# A peer that does not stop in time is sent SIGUSR1 before it is killed: its
# threads' stacks go to its log, which the tests show.
faulthandler.register(signal.SIGUSR1)

import sys  # noqa: E402
import time  # noqa: E402
import xmlrpc.client  # noqa: E402

import rosgraph  # noqa: E402
import rospy  # noqa: E402
from geometry_msgs.msg import Twist, TwistStamped  # noqa: E402


def main() -> None:
    name, role, topic = sys.argv[1:4]
    rospy.init_node(name.lstrip("/"), disable_signals=True)
    if role == "subscriber":
        rospy.Subscriber(topic, Twist, lambda _: None)
        until_listed(topic, "subscriber")
        STOP.wait()
    elif role == "quiet":  # advertises the soak's type and sends nothing
        rospy.Publisher(topic, TwistStamped, queue_size=10)
        until_listed(topic, "publisher")
        STOP.wait()
    else:
        publisher = rospy.Publisher(topic, Twist, queue_size=10)
        until_listed(topic, "publisher")
        if role == "sneak":
            sneak(topic, sys.argv[4])
        message = Twist()
        while not STOP.wait(0.05):
            message.linear.x += 1.0
            publisher.publish(message)
    rospy.signal_shutdown("stopped")


def until_listed(topic: str, role: str, timeout: float = 30.0) -> None:
    """Wait until the master lists this node on `topic`: rospy registers from a
    thread of its own, and a shutdown racing it may unregister before it registers."""
    master, me = rosgraph.Master(rospy.get_name()), rospy.get_name()
    column = 0 if role == "publisher" else 1
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        listed = dict(master.getSystemState()[column])
        if me in listed.get(topic, []):
            return
        time.sleep(0.05)
    raise SystemExit(f"{me}: the master never listed it as a {role} of {topic}")


def sneak(topic: str, subscriber: str) -> None:
    master = xmlrpc.client.ServerProxy(rosgraph.get_master_uri())
    caller, uri = rospy.get_name(), rospy.get_node_uri()
    code, text, _ = master.unregisterPublisher(caller, topic, uri)
    assert code == 1, text
    code, text, target = master.lookupNode(caller, subscriber)
    assert code == 1, text
    code, text, _ = xmlrpc.client.ServerProxy(target).publisherUpdate(caller, topic, [uri])
    assert code == 1, text
    print(f"sneaked {uri}", flush=True)


if __name__ == "__main__":
    main()
