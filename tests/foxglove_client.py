"""A small client of the Foxglove WebSocket protocol, as the Foxglove app speaks it.

Connects with the protocol's subprotocols, reads the JSON ``serverInfo`` and ``advertise``
operations, subscribes to channels and decodes binary ``messageData`` frames (opcode 0x01:
subscription id u32, log time u64, payload, little-endian). Protobuf payloads are decoded
with the schema the server advertised (a base64 ``FileDescriptorSet``), as a client that
knows nothing of the server would; JSON payloads are parsed.
"""

from __future__ import annotations

import base64
import contextlib
import json
import struct
import time
from dataclasses import dataclass
from typing import Any

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from websockets.sync.client import ClientConnection, connect

SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
MESSAGE_DATA = 0x01


@dataclass
class Received:
    """One decoded message of a subscription."""

    topic: str
    log_time_ns: int
    message: Any
    """A protobuf message, or a dict for JSON channels."""


class FoxgloveClient:
    """One connection, as a context manager; ``channels`` maps topic -> the advertised channel
    (JSON dict). Connecting retries until ``connect_timeout_s``: the server may be starting."""

    def __init__(self, url: str, connect_timeout_s: float = 30.0) -> None:
        self.url = url
        self.connect_timeout_s = connect_timeout_s
        self.server_info: dict[str, Any] | None = None
        self.channels: dict[str, dict[str, Any]] = {}
        self._subscriptions: dict[int, str] = {}
        self._classes: dict[str, Any] = {}
        self._stack = contextlib.ExitStack()

    def __enter__(self) -> FoxgloveClient:
        deadline = time.monotonic() + self.connect_timeout_s
        while True:
            try:
                self.ws: ClientConnection = self._stack.enter_context(
                    connect(self.url, subprotocols=SUBPROTOCOLS)
                )
                return self
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.2)

    def __exit__(self, *exc_info: object) -> None:
        self._stack.close()

    def _handle_text(self, text: str) -> None:
        op = json.loads(text)
        if op["op"] == "serverInfo":
            self.server_info = op
        elif op["op"] == "advertise":
            for channel in op["channels"]:
                self.channels[channel["topic"]] = channel
        elif op["op"] == "unadvertise":
            gone = set(op["channelIds"])
            self.channels = {t: c for t, c in self.channels.items() if c["id"] not in gone}

    def wait_for_channels(self, topics: set[str], timeout_s: float) -> None:
        """Read control messages until every topic in ``topics`` is advertised."""
        deadline = time.monotonic() + timeout_s
        while not topics <= set(self.channels):
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"not advertised: {sorted(topics - set(self.channels))}")
            frame = self.ws.recv(timeout=left)
            if isinstance(frame, str):
                self._handle_text(frame)

    def subscribe(self, topics: list[str]) -> None:
        subscriptions = []
        for topic in topics:
            sub_id = len(self._subscriptions) + 1
            self._subscriptions[sub_id] = topic
            subscriptions.append({"id": sub_id, "channelId": self.channels[topic]["id"]})
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))

    def _decode(self, topic: str, payload: bytes) -> Any:
        channel = self.channels[topic]
        if channel["encoding"] == "json":
            return json.loads(payload)
        assert channel["encoding"] == "protobuf", channel["encoding"]
        name = channel["schemaName"]
        if name not in self._classes:
            files = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
            pool = descriptor_pool.DescriptorPool()
            for file in files.file:
                pool.Add(file)
            self._classes[name] = message_factory.GetMessageClass(pool.FindMessageTypeByName(name))
        return self._classes[name].FromString(payload)

    def receive(self, timeout_s: float) -> Received:
        """The next message of a subscription (control messages are handled on the way)."""
        deadline = time.monotonic() + timeout_s
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("no message")
            frame = self.ws.recv(timeout=left)
            if isinstance(frame, str):
                self._handle_text(frame)
                continue
            if frame[0] != MESSAGE_DATA:
                continue
            sub_id, log_time = struct.unpack_from("<IQ", frame, 1)
            topic = self._subscriptions[sub_id]
            return Received(topic, log_time, self._decode(topic, bytes(frame[13:])))

    def receive_until(self, wanted: set[str], timeout_s: float) -> dict[str, list[Received]]:
        """Messages by topic until each topic in ``wanted`` has at least one."""
        got: dict[str, list[Received]] = {}
        deadline = time.monotonic() + timeout_s
        while not wanted <= set(got):
            left = deadline - time.monotonic()
            try:
                item = self.receive(max(left, 0.0))
            except TimeoutError:
                raise TimeoutError(f"nothing on {sorted(wanted - set(got))}") from None
            got.setdefault(item.topic, []).append(item)
        return got
