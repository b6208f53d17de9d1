"""A live run recorded as a rosbag2 (MCAP), written by a process of its own.

The loop hands each message to :meth:`BagRecorder.record` (its topic, its receive or publication
time, the message or the CDR bytes it sent or received): an append to a queue, no I/O. Every 20 ms
a thread of the loop's process packs what was queued into one batch of bytes and writes it to the
pipe of the bag's writer, a process of its own (:mod:`lwrlab.live.bag_writer`) that writes the bag
with ``rosbags``. The loop's process therefore never runs the bag's Python code: its interpreter's
lock, which the sample path needs, is held by the bag's side only for the packing (tens of µs per
batch). The bag is a ROS 2 bag a ROS user replays (``ros2 bag play``) and ``plant=log`` reads (its
``/joint_states``).
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading
from collections import deque
from pathlib import Path
from typing import Any

from lwrlab.live.bag_writer import pack_record
from lwrlab.live.messages import ros_type_name

DRAIN_PERIOD_S = 0.02
"""How often the queued messages are packed and sent to the writer: in batches, so that the loop's
appends wake nothing (a put that wakes a thread hands it the interpreter's lock, and the sample path
waits for it)."""


class BagRecorder:
    """Messages written into a new rosbag2 folder ``path`` (MCAP) by a writer process.

    Parameters
    ----------
    path : the bag folder to create (must not exist).
    topics : ROS 2 topic → message class of :mod:`lwrlab.live.messages`, every topic recorded.
    """

    def __init__(self, path: str | Path, topics: dict[str, type]) -> None:
        self.path = Path(path)
        if self.path.exists():
            raise FileExistsError(f"{self.path}: exists already; a bag is written into a new folder")
        self._index = {topic: k for k, topic in enumerate(topics)}
        connections = [[topic, ros_type_name(message)] for topic, message in topics.items()]
        self._writer = subprocess.Popen(
            [sys.executable, "-m", "lwrlab.live.bag_writer", str(self.path), json.dumps(connections)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )
        self._queue: deque[tuple[str, int, Any]] = deque()
        self._stop = threading.Event()
        self.written = 0
        self.error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="bag", daemon=True)
        self._thread.start()

    def record(self, topic: str, time_ns: int, message: Any) -> None:
        """Queue ``message`` of ``topic`` (a message, or its CDR bytes) at ``time_ns`` (ns since the
        epoch) for the bag."""
        self._queue.append((topic, time_ns, message))

    def _run(self) -> None:
        while not self._stop.wait(DRAIN_PERIOD_S):
            self._send()
        self._send()

    def _send(self) -> None:
        records = []
        while self._queue:
            topic, time_ns, message = self._queue.popleft()
            data = message if isinstance(message, bytes) else message.serialize()
            records.append(pack_record(self._index[topic], int(time_ns), data))
        if not records or self.error is not None:
            return  # the loop must never block on a failed bag
        batch = b"".join(records)
        try:
            assert self._writer.stdin is not None
            self._writer.stdin.write(len(batch).to_bytes(8, "little") + batch)
            self._writer.stdin.flush()
        except OSError as error:  # the writer ended: close() says why
            self.error = error

    def close(self) -> Path:
        """Write what is queued, close the bag and return its folder; the writer's error, if any."""
        self._stop.set()
        self._thread.join()
        out, err = self._writer.communicate()  # closes its input: the writer closes the bag
        if self._writer.returncode != 0:
            reason = err.decode(errors="replace").strip().splitlines()
            raise RuntimeError(
                f"{self.path}: the bag could not be written: {reason[-1] if reason else self.error}"
            )
        self.written = int(json.loads(out)["written"])
        return self.path


__all__ = ["BagRecorder"]
