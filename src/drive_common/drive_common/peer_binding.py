"""Peer binding: once the lockstep starts, each side hears only its peer (by DDS writer gid).

Every other publisher on the lockstep topics is ignored and reported once. rclpy gives no
publisher per message, so :class:`IdentifiedTake` calls rcl's ``rcl_take_serialized_message``
through ctypes. Rules: docs/architecture.md "Time and lockstep" (peer binding).
"""
from __future__ import annotations

import ctypes
import os
import sys
import threading
from typing import Callable

from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy  # noqa: F401 - loads librcl

from drive_common.namespaces import full_name

GID_SIZE = 16              # RMW_GID_STORAGE_SIZE (rmw/types.h, Jazzy)
NO_GID = bytes(GID_SIZE)   # an RMW that does not say who published
PARTICIPANT_PREFIX = 12    # gid bytes naming the DDS participant (one per process context)
RCL_RET_OK = 0
UNDISCOVERED = 'an undiscovered node'
UNKNOWN_NODE = '_NODE_NAME_UNKNOWN_'   # rmw: an endpoint whose node's name is not known yet


class _Allocator(ctypes.Structure):
    _fields_ = [('allocate', ctypes.c_void_p), ('deallocate', ctypes.c_void_p),
                ('reallocate', ctypes.c_void_p), ('zero_allocate', ctypes.c_void_p),
                ('state', ctypes.c_void_p)]


class _Uint8Array(ctypes.Structure):        # rcutils_uint8_array_t = rcl_serialized_message_t
    _fields_ = [('buffer', ctypes.POINTER(ctypes.c_uint8)), ('buffer_length', ctypes.c_size_t),
                ('buffer_capacity', ctypes.c_size_t), ('allocator', _Allocator)]


class _Gid(ctypes.Structure):               # rmw_gid_t
    _fields_ = [('implementation_identifier', ctypes.c_char_p),
                ('data', ctypes.c_uint8 * GID_SIZE)]


class _MessageInfo(ctypes.Structure):       # rmw_message_info_t
    _fields_ = [('source_timestamp', ctypes.c_int64), ('received_timestamp', ctypes.c_int64),
                ('publication_sequence_number', ctypes.c_uint64),
                ('reception_sequence_number', ctypes.c_uint64),
                ('publisher_gid', _Gid), ('from_intra_process', ctypes.c_bool)]


def _library(name: str) -> ctypes.CDLL:
    """A ROS C library: the one rclpy already loaded, else the environment's lib directory."""
    try:
        return ctypes.CDLL(name)
    except OSError:
        return ctypes.CDLL(os.path.join(sys.prefix, 'lib', name))


_rcl = _library('librcl.so')
_rcutils = _library('librcutils.so')
_rcutils.rcutils_get_default_allocator.restype = _Allocator
_rcutils.rcutils_uint8_array_init.argtypes = [ctypes.POINTER(_Uint8Array), ctypes.c_size_t,
                                              ctypes.POINTER(_Allocator)]
_rcutils.rcutils_uint8_array_fini.argtypes = [ctypes.POINTER(_Uint8Array)]
_rcl.rcl_take_serialized_message.argtypes = [ctypes.c_void_p, ctypes.POINTER(_Uint8Array),
                                             ctypes.POINTER(_MessageInfo), ctypes.c_void_p]


class IdentifiedTake:
    """Take a subscription's messages as CDR bytes with the publisher's gid; one thread only."""

    def __init__(self, subscription) -> None:
        self._sub = subscription
        self._allocator = _rcutils.rcutils_get_default_allocator()
        self._buffer = _Uint8Array()
        self._info = _MessageInfo()
        if _rcutils.rcutils_uint8_array_init(ctypes.byref(self._buffer), 256,
                                             ctypes.byref(self._allocator)) != RCL_RET_OK:
            raise MemoryError('cannot allocate a serialized message buffer')

    def __call__(self) -> tuple[bytes, bytes] | None:
        """(message bytes, publisher gid), or None if nothing is waiting."""
        with self._sub.handle:
            ret = _rcl.rcl_take_serialized_message(self._sub.handle.pointer,
                                                   ctypes.byref(self._buffer),
                                                   ctypes.byref(self._info), None)
        if ret != RCL_RET_OK:
            return None          # RCL_RET_SUBSCRIPTION_TAKE_FAILED: nothing waiting
        return (ctypes.string_at(self._buffer.buffer, self._buffer.buffer_length),
                bytes(self._info.publisher_gid.data))

    def __del__(self) -> None:
        try:
            _rcutils.rcutils_uint8_array_fini(ctypes.byref(self._buffer))
        except Exception:  # noqa: BLE001 - interpreter shutdown
            pass


class PeerBinding:
    """The one peer a node hears on its lockstep topics.

    received: the topic whose publisher is bound; sent: the topic a counterpart subscribes to;
    watched: topics whose other publishers are reported; report(message, values): a WARN
    diagnostic; may_bind(): False once the node found a second graph.
    """

    def __init__(self, node, received: str, sent: str, watched=(),
                 report: Callable[[str, dict[str, str]], None] | None = None,
                 may_bind: Callable[[], bool] = lambda: True) -> None:
        self._node = node
        resolve = node.resolve_topic_name
        self.received, self.sent = resolve(received), resolve(sent)
        self.watched = tuple(resolve(t) for t in (watched or (received, sent)))
        self._report = report
        self._may_bind = may_bind
        self._lock = threading.Lock()
        self.peer: bytes | None = None          # the bound publisher's gid
        self.peer_name = ''
        self._me = (node.get_name(), node.get_namespace())
        self._reported: set[bytes] = set()
        self._unnamed: dict[bytes, str] = {}    # gid -> topic: ignored, not reported yet
        self.intruders: list[str] = []           # node names reported, in order

    @property
    def bound(self) -> bool:
        return self.peer is not None

    def accepts(self, gid: bytes) -> bool:
        """Whether a message from publisher gid is the peer's (binding a counterpart if unbound)."""
        if gid == self.peer or gid == NO_GID:
            return True
        if self.peer is None:
            name = self._counterpart(gid)
            if name is not None and self._may_bind():
                with self._lock:
                    self.peer, self.peer_name = gid, name
                    self._reported.discard(gid)
                    self._unnamed.pop(gid, None)
                self._node.get_logger().info(f'lockstep peer on {self.received}: {name}')
                return True
        if gid not in self._reported and gid not in self._unnamed:
            self._intruder(gid, self.received, self._name_of(self.received, gid), heard=True)
        return False

    def check(self) -> None:
        """Periodic: end the binding if the peer left the graph; report new intruders."""
        for gid, topic in list(self._unnamed.items()):
            self._intruder(gid, topic, self._name_of(topic, gid), heard=True)
        if self.peer is None:
            return
        publishers = {t: self._node.get_publishers_info_by_topic(t) for t in self.watched}
        peer = [i for i in publishers[self.received] if bytes(i.endpoint_gid) == self.peer]
        if peer and (UNKNOWN_NODE in self.peer_name or self.peer_name == UNDISCOVERED):
            self.peer_name = full_name(peer[0].node_name, peer[0].node_namespace)   # named late
        if not peer:
            self._node.get_logger().info(f'lockstep peer {self.peer_name} left the graph: '
                                         f'the next counterpart on {self.received} is bound')
            self.release()
            return
        for topic, infos in publishers.items():
            for i in infos:
                gid = bytes(i.endpoint_gid)
                if ((i.node_name, i.node_namespace) != self._me and gid != self.peer
                        and gid not in self._reported):
                    self._intruder(gid, topic, full_name(i.node_name, i.node_namespace))

    def flush(self) -> None:
        """The end of a run: every intruder still unnamed is reported now, by its gid."""
        for gid, topic in list(self._unnamed.items()):
            name = self._name_of(topic, gid)
            self._intruder(gid, topic, name if self._named(name) else f'{UNDISCOVERED} (publisher '
                           f'gid {gid.hex()})', final=True)

    def release(self) -> None:
        """Forget the peer (the node may bind another one)."""
        with self._lock:
            self.peer, self.peer_name = None, ''
            self._reported.clear()

    def _counterpart(self, gid: bytes) -> str | None:
        """The publisher's node name if its process (gid participant prefix) subscribes to sent;
        None if not (or not discovered yet: its next message is looked at again)."""
        readers = self._node.get_subscriptions_info_by_topic(self.sent)
        if any(bytes(r.endpoint_gid)[:PARTICIPANT_PREFIX] == gid[:PARTICIPANT_PREFIX]
               for r in readers):
            return self._publisher_name(self.received, gid)
        return None

    def _publisher_name(self, topic: str, gid: bytes) -> str:
        for i in self._node.get_publishers_info_by_topic(topic):
            if bytes(i.endpoint_gid) == gid:
                return full_name(i.node_name, i.node_namespace)
        return UNDISCOVERED

    @staticmethod
    def _named(name: str) -> bool:
        return name != UNDISCOVERED and UNKNOWN_NODE not in name

    def _name_of(self, topic: str, gid: bytes) -> str:
        """The node of publisher gid on topic; if unlisted, the named node(s) of its DDS
        participant (a listed one is never named by its participant's other nodes)."""
        name = self._publisher_name(topic, gid)
        if name != UNDISCOVERED:
            return name                  # its node, or rmw's placeholder until the name comes
        prefix, nodes = gid[:PARTICIPANT_PREFIX], set()
        for other, _types in self._node.get_topic_names_and_types():
            for info in (self._node.get_publishers_info_by_topic(other)
                         + self._node.get_subscriptions_info_by_topic(other)):
                if bytes(info.endpoint_gid)[:PARTICIPANT_PREFIX] == prefix:
                    nodes.add(full_name(info.node_name, info.node_namespace))
        nodes = sorted(n for n in nodes if self._named(n))
        if not nodes:
            return name
        return nodes[0] if len(nodes) == 1 else 'one of ' + ', '.join(nodes)

    def _intruder(self, gid: bytes, topic: str, name: str, heard: bool = False,
                  final: bool = False) -> None:
        """Report an intruder once, by node name (log and diagnostic); one not named yet is
        kept (if heard) for a later report, by name or, at the run's end, by gid."""
        with self._lock:
            if (gid in self._reported or gid == self.peer
                    or name == self._node.get_fully_qualified_name()):
                self._unnamed.pop(gid, None)
                return
            if not (final or self._named(name)):
                if heard:
                    self._unnamed[gid] = topic
                return
            self._unnamed.pop(gid, None)
            self._reported.add(gid)
            self.intruders.append(name)
        peer = self.peer_name or 'none'
        message = (f'ignoring {name}: a publisher of {topic} outside this lockstep pair (this node '
                   f'takes {self.received} from {peer} only)')
        self._node.get_logger().warning(message)
        if self._report is not None:
            self._report(message, {'topic': topic, 'intruder': name, 'intruder_gid': gid.hex(),
                                   'bound_peer': peer})
