"""Record the simulated MSL world (pybullet) to ROS 2 MCAP logs.

Importing this package does not import pybullet: the log contract (``recorder.contract``)
is shared with replay. The simulator lives in the submodules that need it.
"""

from recorder import contract

__all__ = ["contract"]
