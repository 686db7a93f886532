"""A graph endpoint in a process of its own, for the intrusion tests and the soak:
one the spec does not allow (a ROS node named `rogue`, or a DDS writer that is no
ROS node at all: cyclonedds, beside Fast DDS), or one it does.
Prints `ready` once its writer exists and leaves cleanly when its stdin closes.

    python intruder.py ros|dds|imposter|allowed-pub|allowed-sub TOPIC

(`imposter`: a node of that name publishing std_msgs/msg/String on the topic;
`allowed-pub` and `allowed-sub`: a /player publisher and a /listener subscriber,
which the soak starts and stops around the nodes.)
"""

# (no `from __future__ import annotations`: cyclonedds reads the field types at
# class creation, from the function's scope)
import sys
from dataclasses import dataclass


def ros(topic: str, name: str = "rogue", kind: str = "TwistStamped") -> None:
    import rclpy
    from geometry_msgs.msg import TwistStamped
    from rclpy.node import Node
    from std_msgs.msg import String

    rclpy.init()
    node = Node(name)
    node.create_publisher({"TwistStamped": TwistStamped, "String": String}[kind], topic, 10)
    print("ready", flush=True)
    sys.stdin.read()
    node.destroy_node()
    rclpy.shutdown()


def allowed_publisher(topic: str) -> None:
    """Another node named `player`, which the whitelist allows to publish."""
    ros(topic, "player")


def allowed_subscriber(topic: str) -> None:
    """A node `listener` reading the topic (the whitelist restricts publishers only)."""
    import rclpy
    from geometry_msgs.msg import TwistStamped
    from rclpy.node import Node

    rclpy.init()
    node = Node("listener")
    node.create_subscription(TwistStamped, topic, lambda _: None, 10)
    print("ready", flush=True)
    sys.stdin.read()
    node.destroy_node()
    rclpy.shutdown()


def imposter(topic: str) -> None:
    """A node `imposter` publishing std_msgs/msg/String on the topic (of another type
    than the spec reads: DDS never matches it with the monitor's reader)."""
    ros(topic, "imposter", "String")


def dds(topic: str) -> None:
    import os

    from cyclonedds.domain import DomainParticipant
    from cyclonedds.idl import IdlStruct
    from cyclonedds.idl.types import float64
    from cyclonedds.pub import DataWriter
    from cyclonedds.topic import Topic

    @dataclass
    class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
        x: float64
        y: float64
        z: float64

    participant = DomainParticipant(int(os.environ["ROS_DOMAIN_ID"]))
    # ROS 2 maps topic /a/b to the DDS topic rt/a/b
    writer = DataWriter(participant, Topic(participant, "rt" + topic, Vector3))
    writer.write(Vector3(1.0, 2.0, 3.0))
    print("ready", flush=True)
    sys.stdin.read()


if __name__ == "__main__":
    kinds = {"ros": ros, "dds": dds, "imposter": imposter, "allowed-pub": allowed_publisher,
             "allowed-sub": allowed_subscriber}  # fmt: skip
    kinds[sys.argv[1]](sys.argv[2])
