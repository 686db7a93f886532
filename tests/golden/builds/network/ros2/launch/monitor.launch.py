"""Start the nodes of network with config/params.yaml."""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch_ros.actions import Node


def generate_launch_description() -> LaunchDescription:
    share = get_package_share_directory("network")
    params = os.path.join(share, "config", "params.yaml")
    return LaunchDescription(
        [
            Node(package="network", executable="monitor",
                 name="rmv_monitor", parameters=[params], output="screen"),
            Node(package="network", executable="intrusion",
                 name="rmv_intrusion", parameters=[params], output="screen"),
        ]
    )  # fmt: skip
