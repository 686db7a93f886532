"""rmvdsl: one specification language for runtime monitoring, verification and
intrusion detection of ROS systems."""

__version__ = "0.1.0"
