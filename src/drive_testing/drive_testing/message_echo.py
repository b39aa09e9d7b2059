"""message_echo: re-publishes every dtc_msgs message type it receives.

For each message type T of dtc_msgs it subscribes ``echo/in/T`` and
publishes the same message on ``echo/out/T`` (lockstep QoS). System tests
use it to prove that every interface crosses a process boundary field-exact.
"""
from __future__ import annotations

import dtc_msgs.msg
from rclpy.node import Node

from drive_common.node_main import run_node
from drive_common.topics import LOCKSTEP_QOS

MESSAGE_TYPES = tuple(sorted(name for name, value in vars(dtc_msgs.msg).items()
                             if isinstance(value, type) and hasattr(value, 'get_fields_and_field_types')))
"""Every message type of dtc_msgs (read from the generated package, not listed by hand)."""


def message_class(name: str) -> type:
    return getattr(dtc_msgs.msg, name)


class MessageEcho(Node):
    def __init__(self, **kwargs) -> None:
        super().__init__('message_echo', **kwargs)
        self.echoed = 0
        for name in MESSAGE_TYPES:
            cls = message_class(name)
            pub = self.create_publisher(cls, f'echo/out/{name}', LOCKSTEP_QOS)
            self.create_subscription(cls, f'echo/in/{name}', self._forward(pub), LOCKSTEP_QOS)

    def _forward(self, pub):
        def callback(msg) -> None:
            pub.publish(msg)
            self.echoed += 1
        return callback


def main(args=None) -> int:
    return run_node(MessageEcho, args)


if __name__ == '__main__':
    raise SystemExit(main())
