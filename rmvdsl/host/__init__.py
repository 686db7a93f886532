"""The runtime's host in a live ROS system: what a generated node does besides
calling ROS, as ordinary modules (tests/test_host.py runs them with no ROS).

Standard library and rmvdsl.runtime only, except `ros2.py`, the one module that
imports rclpy: it wires ROS callbacks to the others. A generated package carries a
copy of this folder as `rmv_host/` beside `rmv_runtime/`, so its nodes run the code
the tests ran; its templates only name the node to start.
"""
