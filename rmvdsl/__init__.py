"""rmvdsl: one specification language for runtime monitoring, verification and
intrusion detection of ROS systems."""

__version__ = "0.1.0"

from rmvdsl.util.compiled import install as _install

_install()  # before any module of rmvdsl makes its dataclasses
