"""The viewer's WebSocket protocol, defined once: validation and the page's documentation.

Every message is a small JSON object with ``"v": VERSION`` and a ``"type"``.  A page
sends the messages in ``CLIENT_MESSAGES``; ``parse_client_message`` refuses bad JSON,
an unknown type, a missing or unknown field, a value of the wrong kind, and numbers
that are not finite or lie outside a field's range, with a ``ProtocolError`` saying
which (the server logs it, answers an ``error`` message and keeps the connection).
``schema_document`` is the same table as JSON: the page reads it from
``/protocol.json`` to list the messages and to set its controls' ranges.

The server sends JSON objects (``hello``, ``event``, ``error``; ``server_message``)
and frames as binary messages (``pack_frame``): a 4-byte big-endian header length,
the UTF-8 JSON header (``"type": "frame"``), then the JPEG.
"""

from __future__ import annotations

import json
import math
import struct
from dataclasses import dataclass
from typing import Any

from ..focus import SHAPES
from ..renderer import MODES

VERSION = 1
#: The largest text message a page may send (bytes); the server closes on larger ones.
MAX_MESSAGE_BYTES = 4096
#: Navigation gestures (``navigate.kind``).
NAVIGATE_KINDS = ("orbit", "pan", "zoom")
RECORD_ACTIONS = ("start", "stop")
CALIBRATE_ACTIONS = ("start", "cancel")


class ProtocolError(ValueError):
    """A message the server refuses; the text says why."""


@dataclass(frozen=True)
class Field:
    """One field of a message: its kind (``number``, ``integer``, ``boolean``, ``choice``,
    ``text``), range or choices, whether it is required, and what it means."""

    name: str
    kind: str
    doc: str
    required: bool = True
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] = ()
    max_length: int = 200

    def check(self, value: Any, where: str) -> Any:
        """``value`` if it fits the field, else a ``ProtocolError`` naming ``where``."""
        name = f"{where}.{self.name}"
        if self.kind in ("number", "integer"):
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ProtocolError(f"{name} must be a number, got {value!r:.40}")
            if self.kind == "integer" and not (isinstance(value, int) or float(value).is_integer()):
                raise ProtocolError(f"{name} must be a whole number, got {value!r}")
            number = float(value)
            if not math.isfinite(number):
                raise ProtocolError(f"{name} must be finite, got {value!r}")
            if (self.low is not None and number < self.low) or (self.high is not None and number > self.high):
                raise ProtocolError(f"{name} must lie in [{self.low:g}, {self.high:g}], got {number:g}")
            return int(number) if self.kind == "integer" else number
        if self.kind == "boolean":
            if not isinstance(value, bool):
                raise ProtocolError(f"{name} must be true or false, got {value!r:.40}")
            return value
        if not isinstance(value, str):
            raise ProtocolError(f"{name} must be a string, got {value!r:.40}")
        if self.kind == "choice" and value not in self.choices:
            raise ProtocolError(f"{name} must be one of {', '.join(self.choices)}, got {value!r:.40}")
        if len(value) > self.max_length:
            raise ProtocolError(f"{name} is longer than {self.max_length} characters")
        return value

    def describe(self) -> dict[str, Any]:
        """The field as JSON (``schema_document``)."""
        doc: dict[str, Any] = {"name": self.name, "kind": self.kind, "required": self.required, "doc": self.doc}
        if self.low is not None:
            doc["min"], doc["max"] = self.low, self.high
        if self.choices:
            doc["choices"] = list(self.choices)
        return doc


@dataclass(frozen=True)
class MessageType:
    """A message a page may send: its fields and what it does."""

    doc: str
    fields: tuple[Field, ...] = ()


#: Every message a page may send, by type.
CLIENT_MESSAGES: dict[str, MessageType] = {
    "pointer": MessageType(
        "the pointer moved (cursor gaze): normalised position, origin top-left",
        (
            Field("x", "number", "0 left .. 1 right", low=0.0, high=1.0),
            Field("y", "number", "0 top .. 1 bottom", low=0.0, high=1.0),
            Field("seq", "integer", "the page's running count of pointer messages", low=0, high=2**53),
            Field("sent_ms", "number", "the page's clock (performance.now) when sent", low=0.0, high=1e12),
        ),
    ),
    "control": MessageType(
        "change how frames are rendered (any subset of the fields)",
        (
            Field("fps", "number", "target frame rate; the budget becomes 1000 / fps", False, 1.0, 240.0),
            Field("budget_ms", "number", "frame-time budget in ms (overrides fps)", False, 1.0, 10000.0),
            Field("mode", "choice", "raster, hybrid or full ray tracing", False, choices=MODES),
            Field("shape", "choice", "focus window shape", False, choices=SHAPES),
        ),
    ),
    "camera": MessageType(
        "look through another of the scene's cameras (and drop any navigation)",
        (Field("name", "text", "camera prim path, one of hello.cameras"),),
    ),
    "navigate": MessageType(
        "orbit, pan or zoom the camera (a drag with the modifier key held)",
        (
            Field("kind", "choice", "orbit, pan or zoom", choices=NAVIGATE_KINDS),
            Field("dx", "number", "horizontal drag, share of the frame width", low=-4.0, high=4.0),
            Field("dy", "number", "vertical drag (down positive), share of the frame height", low=-4.0, high=4.0),
        ),
    ),
    "reset_view": MessageType("back to the scene camera's own view"),
    "play": MessageType("play or pause an animated scene", (Field("playing", "boolean", "true plays, false pauses"),)),
    "seek": MessageType(
        "show the scene at a time",
        (Field("t", "number", "seconds from the start of the stage's time range", low=0.0, high=1e7),),
    ),
    "record": MessageType(
        "start or stop recording the gaze and the camera to a trace file",
        (Field("action", "choice", "start or stop", choices=RECORD_ACTIONS),),
    ),
    "calibrate": MessageType(
        "webcam gaze: start or cancel the 9-target calibration",
        (Field("action", "choice", "start or cancel", choices=CALIBRATE_ACTIONS),),
    ),
}

#: Fields every message carries.
ENVELOPE = ("v", "type")


@dataclass(frozen=True)
class ClientMessage:
    """A validated message: its type and its fields (numbers as float or int)."""

    type: str
    fields: dict[str, Any]


def parse_client_message(text: str | bytes) -> ClientMessage:
    """Validate one text message from a page (module notes); ``ProtocolError`` says why not."""
    if len(text) > MAX_MESSAGE_BYTES:
        raise ProtocolError(f"message longer than {MAX_MESSAGE_BYTES} bytes")
    try:
        doc = json.loads(text, parse_constant=_refuse_constant)
    except (ValueError, UnicodeDecodeError) as exc:
        raise ProtocolError(f"not JSON: {exc}") from None
    if not isinstance(doc, dict):
        raise ProtocolError("a message is a JSON object")
    if doc.get("v") != VERSION or isinstance(doc.get("v"), bool):
        raise ProtocolError(f"protocol version must be {VERSION}, got {doc.get('v')!r:.20}")
    kind = doc.get("type")
    if not isinstance(kind, str) or kind not in CLIENT_MESSAGES:
        raise ProtocolError(f"unknown message type {kind!r:.40}; known: {', '.join(CLIENT_MESSAGES)}")
    spec = CLIENT_MESSAGES[kind]
    names = {f.name for f in spec.fields}
    unknown = sorted(set(doc) - names - set(ENVELOPE))
    if unknown:
        raise ProtocolError(f"{kind}: unknown field(s) {', '.join(repr(u)[:40] for u in unknown)}")
    fields: dict[str, Any] = {}
    for field in spec.fields:
        if field.name in doc:
            fields[field.name] = field.check(doc[field.name], kind)
        elif field.required:
            raise ProtocolError(f"{kind}: missing field {field.name!r}")
    if kind == "control" and not fields:
        raise ProtocolError("control: give at least one of " + ", ".join(sorted(names)))
    return ClientMessage(kind, fields)


def _refuse_constant(name: str) -> None:
    """``json.loads`` hook: NaN and Infinity are not JSON."""
    raise ProtocolError(f"{name} is not a number JSON allows")


def schema_document() -> dict[str, Any]:
    """The client messages as JSON, for the page (``/protocol.json``)."""
    return {
        "v": VERSION,
        "max_message_bytes": MAX_MESSAGE_BYTES,
        "messages": {
            name: {"doc": spec.doc, "fields": [f.describe() for f in spec.fields]}
            for name, spec in CLIENT_MESSAGES.items()
        },
    }


def server_message(kind: str, **fields: Any) -> dict[str, Any]:
    """A JSON message to a page: ``hello``, ``event`` or ``error``."""
    return {"v": VERSION, "type": kind, **fields}


_HEADER_LENGTH = struct.Struct(">I")


def pack_frame(header: dict[str, Any], jpeg: bytes) -> bytes:
    """A binary frame message: header length, JSON header (``type`` "frame"), JPEG."""
    text = json.dumps({"v": VERSION, "type": "frame", **header}, separators=(",", ":"), allow_nan=False).encode()
    return _HEADER_LENGTH.pack(len(text)) + text + jpeg


def unpack_frame(data: bytes) -> tuple[dict[str, Any], bytes]:
    """The header and the JPEG of a binary frame message (``pack_frame``'s inverse)."""
    if len(data) < _HEADER_LENGTH.size:
        raise ProtocolError("frame message too short")
    (length,) = _HEADER_LENGTH.unpack_from(data)
    end = _HEADER_LENGTH.size + length
    if end > len(data):
        raise ProtocolError("frame header runs past the message")
    return json.loads(data[_HEADER_LENGTH.size : end]), data[end:]
