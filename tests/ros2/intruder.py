"""An endpoint the spec does not allow, for the intrusion tests: a ROS node named
`rogue`, or a DDS writer that is no ROS node at all (cyclonedds, beside Fast DDS).
Prints `ready` once its writer exists and leaves cleanly when its stdin closes.

    python intruder.py ros|dds TOPIC
"""

# (no `from __future__ import annotations`: cyclonedds reads the field types at
# class creation, from the function's scope)
import sys
from dataclasses import dataclass


def ros(topic: str) -> None:
    import rclpy
    from geometry_msgs.msg import TwistStamped
    from rclpy.node import Node

    rclpy.init()
    node = Node("rogue")
    node.create_publisher(TwistStamped, topic, 10)
    print("ready", flush=True)
    sys.stdin.read()
    node.destroy_node()
    rclpy.shutdown()


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
    {"ros": ros, "dds": dds}[sys.argv[1]](sys.argv[2])
