"""A live run recorded as a rosbag2 (MCAP), written behind the loop.

The loop hands each message to :meth:`BagRecorder.record` (its topic, its receive or publication
time, the message or the CDR bytes it sent or received): a put on a queue, no I/O. A thread
serialises what is not yet bytes (:mod:`lwrlab.live.messages`) and writes them with ``rosbags``; the bag is
a ROS 2 bag a ROS user replays (``ros2 bag play``) and ``plant=log`` reads (its ``/joint_states``).
"""

from __future__ import annotations

import threading
from collections import deque
from pathlib import Path
from typing import Any

from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from lwrlab.live.messages import ros_type_name

_TYPESTORE = get_typestore(Stores.ROS2_HUMBLE)
DRAIN_PERIOD_S = 0.02
"""How often the writer takes what the loop queued: in batches, so that the loop's puts wake nothing
(a put that wakes a thread hands it the interpreter's lock, and the sample path waits for it)."""


class BagRecorder:
    """Messages written into a new rosbag2 folder ``path`` (MCAP) on a thread of their own.

    Parameters
    ----------
    path : the bag folder to create (must not exist).
    topics : ROS 2 topic → message class of :mod:`lwrlab.live.messages`, every topic recorded.
    """

    def __init__(self, path: str | Path, topics: dict[str, type]) -> None:
        self.path = Path(path)
        if self.path.exists():
            raise FileExistsError(f"{self.path}: exists already; a bag is written into a new folder")
        self._writer = Writer(self.path, version=Writer.VERSION_LATEST, storage_plugin=StoragePlugin.MCAP)
        self._writer.open()
        self._connections = {
            topic: self._writer.add_connection(topic, ros_type_name(message), typestore=_TYPESTORE)
            for topic, message in topics.items()
        }
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
            self._drain()
        self._drain()

    def _drain(self) -> None:
        while self._queue:
            topic, time_ns, message = self._queue.popleft()
            if self.error is not None:
                continue  # the loop must never block on a failed bag
            try:
                data = message if isinstance(message, bytes) else message.serialize()
                self._writer.write(self._connections[topic], int(time_ns), data)
                self.written += 1
            except Exception as error:  # reported by close(), the run goes on
                self.error = error

    def close(self) -> Path:
        """Write what is queued, close the bag and return its folder; the writer's error, if any."""
        self._stop.set()
        self._thread.join()
        self._writer.close()
        if self.error is not None:
            raise RuntimeError(f"{self.path}: the bag could not be written: {self.error}") from self.error
        return self.path


__all__ = ["BagRecorder"]
