"""Peer binding: once the lockstep starts, each side hears only its peer.

The lockstep protocol matches a command to a measurement by step only, so any
other publisher on a lockstep topic could answer or feed a run. Each side binds
to its peer by publisher identity (the DDS writer GUID) when the lockstep
starts: the plant each command topic to the publisher of the first command it
takes, a controller the measurement topic to the publisher of the first
measurement. Only a lockstep counterpart (it also subscribes to this side's
topic) can be bound; every other publisher is then ignored and reported once
(``/diagnostics`` WARN and the log), until the bound publisher leaves the graph.
An intruder whose publisher the graph lists without its node's name yet is
reported once the name comes; one the graph does not list (it sent and left)
is named by its DDS participant's other endpoints, or reported by gid when the
run ends (:meth:`PeerBinding.flush`): never dropped unreported, never named by
a guess while its own name is still coming.

rclpy gives no publisher per message, so :class:`IdentifiedTake` calls rcl's
``rcl_take_serialized_message`` through ctypes (``publisher_gid`` =
``endpoint_gid``). An RMW that leaves it empty binds nothing.
docs/architecture.md "Time and lockstep".
"""
from __future__ import annotations

import ctypes
import os
import sys
import threading
from typing import Callable

from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy  # noqa: F401 - loads librcl

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
    """Take a subscription's messages as CDR bytes with the publisher's gid (rcl's take).

    One buffer per subscription, reused (rcl grows it); one thread only.
    """

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


def endpoint_name(info) -> str:
    """'/ns/node' of a topic endpoint info."""
    return info.node_namespace.rstrip('/') + '/' + info.node_name


class PeerBinding:
    """The one peer a node hears on its lockstep topics (see the module docstring).

    node: the node (graph queries, the log). received: the topic whose
    publisher is bound; sent: the topic this node publishes (a counterpart
    subscribes to it). watched: every lockstep topic on which other publishers
    are reported once bound. report(message, values): a diagnostic (WARN).
    may_bind(): whether the node may bind now (False: it found a second graph
    and refuses to run; a late node must never join a running graph).
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
            self.peer_name = endpoint_name(peer[0])     # its name discovered after binding
        if not peer:
            with self._lock:
                self._node.get_logger().info(f'lockstep peer {self.peer_name} left the graph: '
                                             f'the next counterpart on {self.received} is bound')
                self.peer, self.peer_name = None, ''
                self._reported.clear()
            return
        for topic, infos in publishers.items():
            for i in infos:
                gid = bytes(i.endpoint_gid)
                if ((i.node_name, i.node_namespace) != self._me and gid != self.peer
                        and gid not in self._reported):
                    self._intruder(gid, topic, endpoint_name(i))

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
        """The publisher's node name if it is a lockstep counterpart (it subscribes to sent).

        Same process: the subscription's gid has the publisher's DDS participant prefix
        (a node's name can be discovered later than its endpoints).
        """
        readers = self._node.get_subscriptions_info_by_topic(self.sent)
        if any(bytes(r.endpoint_gid)[:PARTICIPANT_PREFIX] == gid[:PARTICIPANT_PREFIX]
               for r in readers):
            return self._publisher_name(self.received, gid)
        return None      # not discovered yet: not bound (its next message is looked at again)

    def _publisher_name(self, topic: str, gid: bytes) -> str:
        for i in self._node.get_publishers_info_by_topic(topic):
            if bytes(i.endpoint_gid) == gid:
                return endpoint_name(i)
        return UNDISCOVERED

    @staticmethod
    def _named(name: str) -> bool:
        return name != UNDISCOVERED and UNKNOWN_NODE not in name

    def _name_of(self, topic: str, gid: bytes) -> str:
        """The node of publisher gid on topic; if the graph does not list it (it left, or is
        not discovered yet), the node(s) of any endpoint of the same DDS participant.

        A listed publisher whose node's name has not come yet is not named by its
        participant: a process with several nodes would have its other nodes blamed.
        """
        name = self._publisher_name(topic, gid)
        if name != UNDISCOVERED:
            return name                  # its node, or rmw's placeholder until the name comes
        prefix, nodes = gid[:PARTICIPANT_PREFIX], set()
        for other, _types in self._node.get_topic_names_and_types():
            for info in (self._node.get_publishers_info_by_topic(other)
                         + self._node.get_subscriptions_info_by_topic(other)):
                if bytes(info.endpoint_gid)[:PARTICIPANT_PREFIX] == prefix:
                    nodes.add(endpoint_name(info))
        nodes = sorted(n for n in nodes if self._named(n))
        if not nodes:
            return name
        return nodes[0] if len(nodes) == 1 else 'one of ' + ', '.join(nodes)

    def _intruder(self, gid: bytes, topic: str, name: str, heard: bool = False,
                  final: bool = False) -> None:
        """Report an intruder once: log and diagnostic, both with its node name. One the graph
        does not name yet is reported later: seen in the graph, once named; heard (its
        messages taken), by name or, at the run's end, by gid."""
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
