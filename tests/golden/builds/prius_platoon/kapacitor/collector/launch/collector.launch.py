"""Start the nodes of prius_platoon_collector with config/params.yaml."""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch_ros.actions import Node


def generate_launch_description() -> LaunchDescription:
    share = get_package_share_directory("prius_platoon_collector")
    params = os.path.join(share, "config", "params.yaml")
    return LaunchDescription(
        [
            Node(package="prius_platoon_collector", executable="collector",
                 name="rmv_collector", parameters=[params], output="screen"),
        ]
    )  # fmt: skip
