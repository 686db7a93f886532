"""A ROS 1 node for the intrusion tests: `peer.py NAME publisher|subscriber TOPIC`
publishes geometry_msgs/Twist at 20 Hz on TOPIC, or subscribes to it, until
SIGINT or SIGTERM; `peer.py NAME quiet TOPIC` advertises TwistStamped on it and
sends nothing (the soak's publishers that come and go); `peer.py NAME sneak TOPIC
SUBSCRIBER` advertises TOPIC, unregisters it from the master, and hands its address
straight to SUBSCRIBER (its `publisherUpdate`), which connects though the master
never says so."""

from __future__ import annotations

import signal
import sys
import threading
import xmlrpc.client

import rosgraph
import rospy
from geometry_msgs.msg import Twist, TwistStamped


def main() -> None:
    name, role, topic = sys.argv[1:4]
    rospy.init_node(name.lstrip("/"), disable_signals=True)
    stop = threading.Event()
    for number in (signal.SIGINT, signal.SIGTERM):
        signal.signal(number, lambda *_: stop.set())
    if role == "subscriber":
        rospy.Subscriber(topic, Twist, lambda _: None)
        stop.wait()
    elif role == "quiet":  # advertises the soak's type and sends nothing
        rospy.Publisher(topic, TwistStamped, queue_size=10)
        stop.wait()
    else:
        publisher = rospy.Publisher(topic, Twist, queue_size=10)
        if role == "sneak":
            sneak(topic, sys.argv[4])
        message = Twist()
        while not stop.wait(0.05):
            message.linear.x += 1.0
            publisher.publish(message)
    rospy.signal_shutdown("stopped")


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
