"""The first messages of a live run as a bag-like source, so a live run is set up as a bag run is.

:func:`pfpeople.pipeline.sensor_setup.setup_sensors` reads a bag's topics and types, the first message of each
sensor topic (a laser's field of view and range, the default grid) and TF (the mounts). :class:`BufferedSource`
offers the same methods over the messages a live node buffered before it starts: the run is set up from them
exactly as from a bag holding them.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence

from pfpeople.io.bag.reader import IMAGE_TYPES, LASER_TYPES, BagMessage

__all__ = ["BufferedSource"]


class BufferedSource:
    """Buffered messages (in arrival order) with the :class:`~pfpeople.io.bag.reader.BagSource` methods a run's
    setup uses.

    Parameters
    ----------
    messages : sequence of BagMessage
        The messages received so far, in arrival order.
    name : str
        What errors call the source (e.g. ``"the live topics"``).
    """

    def __init__(self, messages: Sequence[BagMessage], *, name: str = "the live topics") -> None:
        self._messages = list(messages)
        self.name = name

    @property
    def topics(self) -> dict[str, str]:
        """Topic -> message type of every topic with a message."""
        return {m.topic: m.msgtype for m in self._messages}

    @property
    def topic_types(self) -> dict[str, tuple[str, ...]]:
        out: dict[str, set[str]] = {}
        for m in self._messages:
            out.setdefault(m.topic, set()).add(m.msgtype)
        return {t: tuple(sorted(v)) for t, v in out.items()}

    @property
    def message_counts(self) -> dict[str, int]:
        counts: dict[str, int] = {}
        for m in self._messages:
            counts[m.topic] = counts.get(m.topic, 0) + 1
        return counts

    @property
    def start_time_ns(self) -> int:
        """The arrival time (ns) of the first message (0 when there is none)."""
        return self._messages[0].bag_time_ns if self._messages else 0

    def require(self, topics: Iterable[str], *, types: dict[str, Sequence[str]] | None = None) -> None:
        """Check that every sensor topic of ``topics`` has a message, of one of ``types[topic]``.

        Raises
        ------
        ValueError
            Naming the topics without a message (sensor topics: LaserScan or image) or of another type.
        """
        have = self.topics
        wanted = dict(types or {})
        for topic in topics:
            allowed = wanted.get(topic)
            if topic not in have:
                if allowed is not None and set(allowed) <= {*LASER_TYPES, *IMAGE_TYPES}:
                    raise ValueError(f"no message on topic {topic!r} in {self.name} yet")
                continue
            if allowed is not None and have[topic] not in allowed:
                raise ValueError(
                    f"topic {topic!r} in {self.name} has message type {have[topic]!r}; expected one of {list(allowed)}"
                )

    def messages(self, topics: Iterable[str]) -> Iterator[BagMessage]:
        """The buffered messages of ``topics``, in arrival order."""
        wanted = set(topics)
        return (m for m in self._messages if m.topic in wanted)
