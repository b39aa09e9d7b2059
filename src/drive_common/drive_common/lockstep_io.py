"""Direct receive for the lockstep hot path: wait on a few subscriptions, no executor.

An executor's ``spin_once`` rebuilds its wait set and task bookkeeping on
every call, which in rclpy costs more than the rest of a lockstep sample.
The lockstep subscriptions therefore live on a private node that no
executor spins, and :class:`DirectReceiver` waits on them with one
persistent rcl wait set and hands each message to the subscription's
callback, the way rclpy's own ``wait_for_message`` does. Services,
parameters and actions stay on the node's normal executor.
"""
from __future__ import annotations

from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy


class DirectReceiver:
    """Wait on subscriptions of an un-spun node and dispatch what arrives."""

    def __init__(self, context, subscriptions, with_info: bool = False) -> None:
        """with_info: call ``callback(msg, message_info)`` (timestamps), else ``callback(msg)``."""
        self._subscriptions = list(subscriptions)
        self._with_info = with_info
        self._wait_set = _rclpy.WaitSet(len(self._subscriptions), 0, 0, 0, 0, 0, context.handle)

    def poll(self, timeout: float) -> int:
        """Wait up to timeout s (0: only what has arrived); dispatch every message; count them."""
        wait_set = self._wait_set
        wait_set.clear_entities()
        for sub in self._subscriptions:
            wait_set.add_subscription(sub.handle)
        wait_set.wait(max(0, int(timeout * 1e9)))
        ready = wait_set.get_ready_entities('subscription')
        dispatched = 0
        for sub in self._subscriptions:
            if sub.handle.pointer not in ready:
                continue
            while True:
                with sub.handle:
                    taken = sub.handle.take_message(sub.msg_type, sub.raw)
                if taken is None:
                    break
                if self._with_info:
                    sub.callback(taken[0], taken[1])
                else:
                    sub.callback(taken[0])
                dispatched += 1
        return dispatched
