"""Readers of a real robot's recordings.

Carmen logs (``carmen``) and ROS 1 / ROS 2 bags imported as a dataset (``rosbag``, decoding
messages with ``ros_messages`` and making frames of them by the rule of ``alignment``).
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "CarmenError": "sim.readers.carmen",
        "CarmenLog": "sim.readers.carmen",
        "read_carmen": "sim.readers.carmen",
        "ImportSettings": "sim.readers.alignment",
        "import_rosbags": "sim.readers.rosbag",
        "RosbagImportError": "sim.readers.ros_messages",
    },
)
