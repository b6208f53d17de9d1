"""The bag's writer process: batches of messages read from its standard input, written as a rosbag2 (MCAP).

:class:`lwrlab.live.recorder.BagRecorder` starts it beside a live loop::

    python -m lwrlab.live.bag_writer <bag folder> '[["/joint_states", "sensor_msgs/msg/JointState"], …]'

Its input is a sequence of batches, each an 8-byte little-endian length then that many bytes of
records (:func:`pack_record`: the topic's index in the list, the time in ns, the CDR bytes). At the
end of its input it closes the bag and prints ``{"written": <messages>}``; on an error it says it on
standard error and exits with 1.
"""

from __future__ import annotations

import json
import struct
import sys
from collections.abc import Iterator
from typing import BinaryIO

RECORD_HEAD = struct.Struct("<HqI")
"""A record's head: topic index (u16), time (ns since the epoch, i64), length of its bytes (u32)."""


def pack_record(topic_index: int, time_ns: int, data: bytes) -> bytes:
    """One message's record: its head then its CDR bytes."""
    return RECORD_HEAD.pack(topic_index, time_ns, len(data)) + data


def unpack_records(batch: bytes) -> Iterator[tuple[int, int, bytes]]:
    """(topic index, time ns, CDR bytes) of every record of ``batch``."""
    view, offset = memoryview(batch), 0
    while offset < len(batch):
        index, time_ns, size = RECORD_HEAD.unpack_from(view, offset)
        offset += RECORD_HEAD.size
        yield index, time_ns, bytes(view[offset : offset + size])
        offset += size


def _batches(stream: BinaryIO) -> Iterator[bytes]:
    while True:
        head = stream.read(8)
        if len(head) < 8:
            return
        size = int.from_bytes(head, "little")
        batch = stream.read(size)
        if len(batch) < size:
            raise EOFError(f"a batch cut short: {len(batch)} of {size} bytes")
        yield batch


def write_bag(path: str, connections: list[tuple[str, str]], stream: BinaryIO) -> int:
    """Write every batch of ``stream`` into a new bag folder ``path``; the number of messages written."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_HUMBLE)
    writer = Writer(path, version=Writer.VERSION_LATEST, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    written = 0
    try:
        added = [writer.add_connection(topic, kind, typestore=typestore) for topic, kind in connections]
        for batch in _batches(stream):
            for index, time_ns, data in unpack_records(batch):
                writer.write(added[index], time_ns, data)
                written += 1
    finally:
        writer.close()
    return written


def main(argv: list[str]) -> int:
    path, connections = argv[0], [tuple(pair) for pair in json.loads(argv[1])]
    try:
        written = write_bag(path, connections, sys.stdin.buffer)
    except Exception as error:  # said to the recorder, which raises it with the bag's path
        print(f"{type(error).__name__}: {error}", file=sys.stderr)
        return 1
    print(json.dumps({"written": written}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
