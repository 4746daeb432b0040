"""LCM's encoding as the test scripts write and read it by hand, with no LCM
library (tests/support/flood_lcm.py, spoof_lcm.py): the short-message header,
strings, the clm_lcm types' fingerprints and the mac of the operators' key
(daemon/telemetry/message_mac.hpp)."""
import hashlib
import hmac
import os
import struct

MAGIC_SHORT = 0x4C433032  # "LC02"
MAGIC_FRAGMENT = 0x4C433033  # "LC03"
MAC_BYTES = 32
# The types' fingerprints are read from the fuzz corpus (lcm-gen's encodings),
# so no script carries a stale one.
CORPUS = os.path.join(os.path.dirname(__file__), "..", "fuzz", "corpus", "lcm_datagram")


def corpus_hash(name):
    """The 8-byte fingerprint of the corpus message `name` (its file's bytes 1..8)."""
    with open(os.path.join(CORPUS, name), "rb") as f:
        return f.read()[1:9]


def lcm_string(text):
    data = text.encode() + b"\0"
    return struct.pack(">i", len(data)) + data


def read_string(payload, pos):
    """(text, position after it) of the LCM string at `pos`."""
    (length,) = struct.unpack_from(">i", payload, pos)
    return payload[pos + 4:pos + 4 + length - 1].decode(errors="replace"), pos + 4 + length


def short_datagram(sequence, channel, payload):
    return struct.pack(">II", MAGIC_SHORT, sequence & 0xFFFFFFFF) + channel.encode() + b"\0" + payload


def signed(key, channel, payload):
    """`payload` with its last 32 bytes (the mac field) the HMAC-SHA256 of the channel, a NUL and the rest."""
    body = bytes(payload[:-MAC_BYTES])
    return body + hmac.new(key, channel.encode() + b"\0" + body, hashlib.sha256).digest()
