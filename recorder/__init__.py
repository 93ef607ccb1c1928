"""Record the simulated MSL world (pybullet) to ROS 2 MCAP logs.

Importing this package does not import pybullet: the log contract (``dsp.contract``) is
shared with replay. The simulator lives in the submodules that need it.
"""

__all__: list[str] = []
