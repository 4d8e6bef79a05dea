"""Message definitions of mavros_msgs that ROS 2 bags recorded through MAVROS use but
do not embed (a Humble sqlite3 bag stores type names only, and rosbags' type stores
hold the standard messages, not mavros_msgs).

Written from the published interface: repository ``mavlink/mavros``, folder
``mavros_msgs/msg/`` (commit f8f462dd742056bfba96ddda33b129a75dc6de46, September
2025): the fields of OverrideRCIn, RCIn, RCOut, State and ManualControl as declared
there, in their order. Constants are left out where they do not change the wire
format (State's mode-name strings); OverrideRCIn's CHAN_RELEASE = 0 and
CHAN_NOCHANGE = 65535 are kept, since sampledyn reads them.
"""

from __future__ import annotations

__all__ = ["MAVROS_MSGS"]

#: ROS 2 type name -> .msg text.
MAVROS_MSGS: dict[str, str] = {
    "mavros_msgs/msg/OverrideRCIn": (
        "uint16 CHAN_RELEASE=0\nuint16 CHAN_NOCHANGE=65535\nuint16[18] channels\n"
    ),
    "mavros_msgs/msg/RCIn": "std_msgs/Header header\nuint8 rssi\nuint16[] channels\n",
    "mavros_msgs/msg/RCOut": "std_msgs/Header header\nuint16[] channels\n",
    "mavros_msgs/msg/State": (
        "std_msgs/Header header\nbool connected\nbool armed\nbool guided\n"
        "bool manual_input\nstring mode\nuint8 system_status\n"
    ),
    "mavros_msgs/msg/ManualControl": (
        "std_msgs/Header header\nfloat32 x\nfloat32 y\nfloat32 z\nfloat32 r\n"
        "uint16 buttons\nuint16 buttons2\nuint8 enabled_extensions\nfloat32 s\nfloat32 t\n"
        "float32 aux1\nfloat32 aux2\nfloat32 aux3\nfloat32 aux4\nfloat32 aux5\nfloat32 aux6\n"
    ),
}

#: Pilot-input messages: RC channels or sticks, not motor outputs.
PILOT_INPUTS = (
    "mavros_msgs/msg/OverrideRCIn",
    "mavros_msgs/msg/RCIn",
    "mavros_msgs/msg/ManualControl",
)
