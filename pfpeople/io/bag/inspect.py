"""What is in a bag, and a starter run configuration for it (``pfpeople inspect BAG``).

:func:`inspect_bag` reads a bag once through :class:`pfpeople.io.bag.reader.BagSource`: the record time of every
message (without decoding it) for counts, rates and the time span, and decodes only what it needs:

- the first ``sample`` messages of every topic: header frame ids and the header-stamp minus record-time offset
  (median, s) and the header-stamp rate; for ``sensor_msgs/LaserScan`` also the geometry (angles, beams,
  increment sign, range interval) and whether it changes between those messages; for ``nav_msgs/Odometry``
  the frame and child frame;
- every ``tf2_msgs/TFMessage`` on ``/tf`` and ``/tf_static``: the TF tree as 2-D edges parent -> child
  (x, y, yaw: the planar projection of :mod:`pfpeople.io.bag.tf`, latest transform per edge).

Rates are (count - 1) / (last - first record time) in Hz. Angles are reported in degrees (display) and kept in
radians where a configuration needs them.

:func:`starter_config` turns a report into the TOML text of a run configuration (format:
:mod:`pfpeople.config`) that ``pfpeople run BAG --config FILE`` accepts unchanged:

- ``[frames] driver``: the LaserScan topic with the most messages (ties: the first by name); it makes the frames
  and the others' scans are assigned to them (``nearest``). ``time_source = "bag"`` when the driver's header
  stamps are more than :data:`TIME_SOURCE_THRESHOLD_S` (1 s, median) from its record times (e.g. leg_tracker's
  person_following_outdoor_1, ~130 s), else ``"header"``; but ``"header"`` whenever the driver's messages were
  recorded in a burst (:attr:`TopicInfo.record_burst`: a re-written bag whose record times carry no timing, as
  leg_tracker's ``positive_*_extracted.bag``: 197 scans stamped over 52 s, recorded within 0.5 s).
  ``sync_tolerance_s`` when another laser's scans lie further from the driver's than the default
  :data:`SYNC_TOLERANCE_S` allows (1.25 x its :attr:`LaserInfo.sync_gap_s`, at most half the driver's period;
  leg_tracker's negative_2: /right_scan ~47 ms from /left_scan, 0.06 s).
- ``[odometry] topic``: the ``nav_msgs/Odometry`` topic with the most messages, when one exists; then
  ``base_frame`` is its child frame, and when no TF connects it to the laser a ``[mounts]`` entry places the
  laser at the base origin (flagged in a comment and in the report's warnings: measure it).
- on every LaserScan topic the detectors of :data:`LASER_DETECTORS`: ``laser_legs`` (kind ``leg``),
  ``laser_boosted`` (kind ``boosted``), ``laser_single_legs`` (kind ``single-legs``), so named on the driver
  and ``NAME_TOPIC`` on the others (:func:`laser_detector_name`: ``laser_legs_rear_scan``; valid ROS names, so a
  result bag's detection topics keep them), each with
  ``[detectors.model] fov_min, fov_max, max_range`` from its scan (radians, metres). The run places each laser
  by TF (its mount in the grid frame, :mod:`pfpeople.pipeline.sensor_setup`); a laser that TF does not connect to the
  driver's frame gets a ``[mounts]`` entry at the base origin, facing forward (on the root of its TF tree, and
  the driver's too unless TF connects that to the base frame), flagged "NO TF connects ...: measure it" in a
  comment and in the report's warnings (leg_tracker's negative_2: three lasers, no TF). After them, commented out
  (active with ``opt_in``), the :data:`OPT_IN_DETECTORS` (``laser_learned``, kind ``learned``) where the laser's
  beams are spaced like those its model was trained on (:func:`laser_suits`), else a comment saying why not.
- no ``[filter]`` and no ``[grid]`` table: the product's defaults apply.
"""

from __future__ import annotations

import bisect
import json
import math
import re
import statistics
import textwrap
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

from gridbridge.geometry import Pose2D
from pfpeople.io.bag.reader import LASER_TYPES, ODOMETRY_TYPES, TF_TYPES, BagReadError, BagSource, header_stamp_ns
from pfpeople.io.bag.tf import TfBuffer, TfLookupError, yaw_from_quaternion
from pfpeople.io.jsonio import json_safe

__all__ = [
    "LASER_DETECTORS",
    "OPT_IN_DETECTORS",
    "RECORD_BURST_RATIO",
    "SYNC_TOLERANCE_S",
    "TIME_SOURCE_THRESHOLD_S",
    "BagReport",
    "LaserInfo",
    "OdometryInfo",
    "TfEdge",
    "TopicInfo",
    "format_report",
    "inspect_bag",
    "inspect_path",
    "laser_detector_name",
    "laser_suits",
    "starter_config",
]

#: Median |header stamp - record time| (s) of the driver above which frames are synchronised on bag time.
TIME_SOURCE_THRESHOLD_S = 1.0

#: A run's default ``[frames] sync_tolerance_s`` (s); a starter config raises it when another laser needs more.
SYNC_TOLERANCE_S = 0.05

#: What a run (recommended mode) does without an odometry topic: the report and the starter config say it.
NO_ODOMETRY = (
    "a run moves the grid by scan matching the driving laser where its scans match ([clutter] laser_odometry, "
    "the recommended mode) and takes the robot as standing where they do not (counted: run.json stats ego_motion)"
)

#: A topic's sampled messages were recorded in a burst when their record times span less than this fraction of
#: the time their header stamps span (:attr:`TopicInfo.record_burst`).
RECORD_BURST_RATIO = 0.25


@dataclass(frozen=True, kw_only=True)
class TopicInfo:
    """One topic: type, message count, rate (Hz, from record times), header frame ids, stamp offset (s).

    ``header_rate_hz`` is the rate of the header stamps of the sampled messages (None without headers); it
    differs from ``rate_hz`` in bags whose messages were re-recorded (e.g. leg_tracker's extracted bags).
    ``record_burst`` is True when the sampled messages' record times span less than :data:`RECORD_BURST_RATIO`
    of their header stamps' span (at least 3 stamped messages, header span above 0.1 s): the bag was written
    after the fact and its record times do not time the messages (leg_tracker's ``positive_1_extracted.bag``:
    /training_scan at 408.75 Hz of record time, 3.78 Hz of header stamps).
    """

    topic: str
    msgtype: str
    count: int
    rate_hz: float | None
    frame_ids: tuple[str, ...]
    header_offset_s: float | None
    first_ns: int
    last_ns: int
    header_rate_hz: float | None = None
    record_burst: bool = False


@dataclass(frozen=True, kw_only=True)
class LaserInfo:
    """Geometry of a ``sensor_msgs/LaserScan`` topic (from its first message; ``varies`` if it changes).

    Angles in the scan's frame (REP-103, CCW); ``fov_min_rad``/``fov_max_rad`` are the smallest and largest
    beam angles whatever the sign of the increment. ``mount_in_base`` and ``mount_in_driver`` are the pose
    (x, y, yaw) of the scan's frame in the base frame and in the driving laser's frame from TF (None when TF
    does not connect them; the driver's own ``mount_in_driver`` is the identity). ``sync_gap_s`` (not for
    the driver): over the sampled driver scans in this topic's sampled time span, the 95th percentile of the
    time (s, on the report's time source) from a driver scan to this topic's nearest message, i.e. what a run's
    ``sync_tolerance_s`` must cover for this laser to have data in (nearly) every frame.
    """

    topic: str
    frame_id: str
    beams: int
    angle_min_deg: float
    angle_max_deg: float
    angle_increment_deg: float
    increment_sign: int
    fov_min_rad: float
    fov_max_rad: float
    range_min_m: float
    range_max_m: float
    varies: bool
    mount_in_base: tuple[float, float, float] | None = None
    mount_in_driver: tuple[float, float, float] | None = None
    sync_gap_s: float | None = None


@dataclass(frozen=True, kw_only=True)
class OdometryInfo:
    """A ``nav_msgs/Odometry`` topic: its frame (odom) and child frame (the robot's base)."""

    topic: str
    frame_id: str
    child_frame_id: str
    count: int
    rate_hz: float | None


@dataclass(frozen=True, kw_only=True)
class TfEdge:
    """Latest 2-D transform parent -> child (pose of child in parent: x, y in m, yaw in rad)."""

    parent: str
    child: str
    x: float
    y: float
    yaw: float
    static: bool
    count: int


@dataclass(frozen=True, kw_only=True)
class BagReport:
    """Everything :func:`inspect_bag` found (see the module docstring)."""

    bag: str
    storage: str
    start_ns: int
    end_ns: int
    topics: tuple[TopicInfo, ...]
    lasers: tuple[LaserInfo, ...]
    odometry: tuple[OdometryInfo, ...]
    tf: tuple[TfEdge, ...]
    driver: str | None
    time_source: str
    warnings: tuple[str, ...] = field(default=())

    @property
    def duration_s(self) -> float:
        return (self.end_ns - self.start_ns) / 1e9

    def to_dict(self) -> dict[str, Any]:
        """A JSON-able mapping (:mod:`pfpeople.io.jsonio`: NaN as None, infinities as ``"inf"`` / ``"-inf"``)."""
        out = asdict(self)
        out["duration_s"] = self.duration_s
        return json_safe(out)


def _rate(count: int, first_ns: int, last_ns: int) -> float | None:
    return (count - 1) / ((last_ns - first_ns) / 1e9) if count >= 2 and last_ns > first_ns else None


def _laser_geometry(msg: Any) -> tuple[float, float, float, int, float, float]:
    n = len(msg.ranges)
    return (
        float(msg.angle_min),
        float(msg.angle_max),
        float(msg.angle_increment),
        n,
        float(msg.range_min),
        float(msg.range_max),
    )


def inspect_bag(bag: BagSource, *, sample: int = 200, name: str | None = None) -> BagReport:
    """Inspect an open bag (see the module docstring).

    Parameters
    ----------
    bag : BagSource
        The open bag.
    sample : int
        Messages decoded per topic (TF topics: all) for frame ids, stamp offsets and scan geometry.
    name : str, optional
        Name of the bag in the report (default: the opened path; a zip's is its extracted copy).

    Returns
    -------
    BagReport
    """
    if sample < 1:
        raise ValueError(f"sample must be a positive number of messages, got {sample}")
    types, mixed = _topic_types(bag)
    tf_topics = {t for t, m in types.items() if m in TF_TYPES}
    times, decoded = _read_messages(bag, sample, tf_topics, set(mixed))
    warnings = [
        f"topic {t} carries {len(m)} message types ({', '.join(m)}): left out of this report's lasers, odometry "
        "and TF and of the config (a run refuses a topic with two types)"
        for t, m in sorted(mixed.items())
    ]
    topics = [_topic_info(t, types, mixed, times.get(t, []), decoded.get(t, [])) for t in sorted({*types, *mixed})]
    by_topic = {i.topic: i for i in topics}
    tf, tfbuf = _tf_edges(tf_topics, decoded)
    odometry = _odometry_infos(types, decoded, by_topic, warnings)
    base = max(odometry, key=lambda o: o.count).child_frame_id if odometry else "base_link"
    base = base or "base_link"
    lasers = [
        _laser_info(topic, decoded[topic], tfbuf, base, warnings)
        for topic in sorted(t for t, m in types.items() if m in LASER_TYPES)
        if _has_messages(topic, decoded, "LaserScan", warnings)
    ]
    driver, time_source = _driver_and_time_source(lasers, by_topic, warnings)
    if driver is not None:
        sync = {li.topic: _sync_stamps(decoded.get(li.topic, []), time_source) for li in lasers}
        lasers = _relate_to_driver(lasers, driver, tfbuf, sync, base=base, odometry=bool(odometry), warnings=warnings)
    storage = "ROS 1 bag" if all(p.suffix == ".bag" for p in bag.paths) else "ROS 2 bag"
    return BagReport(
        bag=name or bag.name,
        storage=storage + (" (zip)" if name and name.endswith(".zip") else ""),
        start_ns=bag.start_time_ns,
        end_ns=bag.end_time_ns,
        topics=tuple(topics),
        lasers=tuple(lasers),
        odometry=tuple(odometry),
        tf=tf,
        driver=driver,
        time_source=time_source,
        warnings=tuple(warnings),
    )


def _read_messages(
    bag: BagSource, sample: int, tf_topics: set[str], mixed: set[str]
) -> tuple[dict[str, list[int]], dict[str, list[tuple[int, Any]]]]:
    """Every message's record time per topic, and the first ``sample`` messages decoded (TF topics: all; topics
    of several types: none), as ``(bag time ns, message)``.

    Raises
    ------
    BagReadError
        A truncated or corrupt bag (naming the last message read), or a message that does not decode.
    """
    reader = bag._reader  # BagSource's reader (same package): record times without decoding
    times: dict[str, list[int]] = {}
    decoded: dict[str, list[tuple[int, Any]]] = {}
    it = reader.messages()
    last = "the start"
    while True:
        try:
            conn, bag_time, raw = next(it)
        except StopIteration:
            break
        except Exception as exc:  # rosbags raises several error types for damaged files
            raise BagReadError(
                f"bag {bag.name!r} is truncated or corrupt after {last}: {type(exc).__name__}: {exc}"
            ) from None
        topic = conn.topic
        t = times.setdefault(topic, [])
        t.append(int(bag_time))
        last = f"message {len(t) - 1} of {topic!r} at bag time {bag_time} ns"
        dec = decoded.setdefault(topic, [])
        if topic in mixed:
            continue  # reported with its types, not decoded
        if topic in tf_topics or len(dec) < sample:
            try:
                dec.append((int(bag_time), reader.deserialize(raw, conn.msgtype)))
            except Exception as exc:
                raise BagReadError(
                    f"cannot decode a {conn.msgtype} message on topic {topic!r} at bag time {bag_time} ns "
                    f"in {bag.name!r}: {type(exc).__name__}: {exc}"
                ) from None
    return times, decoded


def _topic_info(
    topic: str,
    types: dict[str, str],
    mixed: dict[str, tuple[str, ...]],
    t: list[int],
    msgs: list[tuple[int, Any]],
) -> TopicInfo:
    """One topic's counts, rates, frame ids and header-stamp offsets from its record times ``t`` (ns) and its
    decoded ``msgs``."""
    ids = sorted({str(m.header.frame_id).lstrip("/") for _, m in msgs if hasattr(m, "header")})
    stamps = [(bt, s) for bt, m in msgs if (s := header_stamp_ns(m)) is not None]
    offsets = [(s - bt) / 1e9 for bt, s in stamps]
    hs = sorted(s for _, s in stamps)
    burst = False
    if len(stamps) >= 3 and hs[-1] - hs[0] > 100_000_000:
        bts = [bt for bt, _ in stamps]
        burst = max(bts) - min(bts) < RECORD_BURST_RATIO * (hs[-1] - hs[0])
    return TopicInfo(
        topic=topic,
        msgtype=" | ".join(mixed[topic]) if topic in mixed else types[topic],
        count=len(t),
        rate_hz=_rate(len(t), t[0], t[-1]) if t else None,
        frame_ids=tuple(ids),
        header_offset_s=statistics.median(offsets) if offsets else None,
        first_ns=t[0] if t else 0,
        last_ns=t[-1] if t else 0,
        header_rate_hz=_rate(len(hs), hs[0], hs[-1]) if hs else None,
        record_burst=burst,
    )


def _tf_edges(tf_topics: set[str], decoded: dict[str, list[tuple[int, Any]]]) -> tuple[tuple[TfEdge, ...], TfBuffer]:
    """The TF tree: each edge's latest transform (by header stamp) with its message count, and a buffer of all."""
    edges: dict[tuple[str, str], tuple[Pose2D, int, bool, int]] = {}
    tfbuf = TfBuffer()
    for topic in sorted(tf_topics):
        static = topic.endswith("tf_static")
        for _, msg in decoded.get(topic, []):
            tfbuf.add_message(msg, topic=topic)
            for tr in msg.transforms:
                parent, child = str(tr.header.frame_id).lstrip("/"), str(tr.child_frame_id).lstrip("/")
                stamp = int(tr.header.stamp.sec) * 1_000_000_000 + int(tr.header.stamp.nanosec)
                tt, q = tr.transform.translation, tr.transform.rotation
                pose = Pose2D(x=float(tt.x), y=float(tt.y), yaw=yaw_from_quaternion(q.x, q.y, q.z, q.w))
                old = edges.get((parent, child))
                count = 1 + (old[3] if old else 0)
                if old is None or old[1] <= stamp:
                    edges[(parent, child)] = (pose, stamp, static, count)
                else:
                    edges[(parent, child)] = (*old[:3], count)
    tf = tuple(
        TfEdge(parent=p, child=c, x=pose.x, y=pose.y, yaw=pose.yaw, static=st, count=n)
        for (p, c), (pose, _, st, n) in sorted(edges.items())
    )
    return tf, tfbuf


def _has_messages(topic: str, decoded: dict[str, list[tuple[int, Any]]], kind: str, warnings: list[str]) -> bool:
    """Whether ``topic`` has decoded messages; a warning when it has none."""
    if decoded.get(topic):
        return True
    warnings.append(f"{kind} topic {topic} has no messages")
    return False


def _odometry_infos(
    types: dict[str, str],
    decoded: dict[str, list[tuple[int, Any]]],
    by_topic: dict[str, TopicInfo],
    warnings: list[str],
) -> list[OdometryInfo]:
    """The odometry topics with their frames (from the first message), counts and rates."""
    out: list[OdometryInfo] = []
    for topic in sorted(t for t, m in types.items() if m in ODOMETRY_TYPES):
        if not _has_messages(topic, decoded, "odometry", warnings):
            continue
        first = decoded[topic][0][1]
        info = by_topic[topic]
        out.append(
            OdometryInfo(
                topic=topic,
                frame_id=str(first.header.frame_id).lstrip("/"),
                child_frame_id=str(first.child_frame_id).lstrip("/"),
                count=info.count,
                rate_hz=info.rate_hz,
            )
        )
    return out


def _laser_info(
    topic: str, decoded: list[tuple[int, Any]], tfbuf: TfBuffer, base: str, warnings: list[str]
) -> LaserInfo:
    """One LaserScan topic's geometry (its first usable scan), its mount in ``base`` from TF (None when TF has no
    path) and the warnings about it."""
    msgs = [m for _, m in decoded]
    first = _first_usable_scan(topic, msgs, warnings)
    geo = _laser_geometry(first)
    a_min, a_max, inc, n, r_min, r_max = geo
    last_angle = a_min + inc * max(n - 1, 0)
    frame_id = str(first.header.frame_id).lstrip("/")
    mount: tuple[float, float, float] | None = None
    if frame_id and tfbuf.frames:
        try:
            p = tfbuf.lookup(base, frame_id)
            mount = (p.x, p.y, p.yaw)
        except TfLookupError:
            mount = None
    varies = any(_laser_geometry(m) != geo for m in msgs[1:])
    if varies:
        warnings.append(f"{topic}: the scan geometry changes between messages (the first one is reported)")
    if inc < 0:
        warnings.append(
            f"{topic}: negative angle_increment (beams run clockwise: a laser mounted upside down or reversed)"
        )
    if not (math.isfinite(r_max) and r_max > 0) or not (math.isfinite(r_min) and r_min < r_max):
        warnings.append(f"{topic}: range interval [{r_min}, {r_max}] m is not a valid interval")
    return LaserInfo(
        topic=topic,
        frame_id=frame_id,
        beams=n,
        angle_min_deg=math.degrees(a_min),
        angle_max_deg=math.degrees(a_max),
        angle_increment_deg=math.degrees(inc),
        increment_sign=1 if inc > 0 else -1 if inc < 0 else 0,
        fov_min_rad=min(a_min, last_angle),
        fov_max_rad=max(a_min, last_angle),
        range_min_m=r_min,
        range_max_m=r_max,
        varies=varies,
        mount_in_base=mount,
    )


def _driver_and_time_source(
    lasers: list[LaserInfo], by_topic: dict[str, TopicInfo], warnings: list[str]
) -> tuple[str | None, str]:
    """The driver (the LaserScan topic with the most messages) and the time source its stamps call for."""
    if not lasers:
        warnings.append("no sensor_msgs/LaserScan topic: a run needs a driver topic (see pfpeople run --driver)")
        return None, "header"
    driver = sorted(lasers, key=lambda li: (-by_topic[li.topic].count, li.topic))[0].topic
    info = by_topic[driver]
    if info.record_burst:
        warnings.append(
            f"the driver {driver!r} was recorded in a burst ({_fmt(info.rate_hz)} Hz of record time, "
            f"{_fmt(info.header_rate_hz)} Hz of header stamps): its record times carry no timing; "
            "synchronise on header stamps (time_source = header)"
        )
        return driver, "header"
    off = info.header_offset_s
    return driver, "bag" if off is not None and abs(off) > TIME_SOURCE_THRESHOLD_S else "header"


def _topic_types(bag: BagSource) -> tuple[dict[str, str], dict[str, tuple[str, ...]]]:
    """``(topic -> type, topic -> types)``: the topics of one message type, and those carrying several."""
    all_types = bag.topic_types
    single = {t: m[0] for t, m in all_types.items() if len(m) == 1}
    return single, {t: m for t, m in all_types.items() if len(m) > 1}


def _first_usable_scan(topic: str, msgs: Sequence[Any], warnings: list[str]) -> Any:
    """The first LaserScan of ``msgs`` with two or more beams over a span (the run's rule,
    :mod:`pfpeople.pipeline.sensor_setup`); a warning when scans before it give none (the first one when no scan
    does)."""
    for k, m in enumerate(msgs):
        a0, a1 = float(m.angle_min), float(m.angle_max)
        if len(m.ranges) >= 2 and math.isfinite(a0) and math.isfinite(a1) and a0 != a1:
            if k:
                warnings.append(
                    f"{topic}: its first {k} scan(s) give no field of view ({len(msgs[0].ranges)} beam(s), angle_min="
                    f"{float(msgs[0].angle_min):.4f}, angle_max={float(msgs[0].angle_max):.4f}): scan {k} is reported "
                    "(the run takes its field of view from it too)"
                )
            return m
    warnings.append(f"{topic}: none of the {len(msgs)} scans read gives a field of view (a run refuses this laser)")
    return msgs[0]


def _sync_stamps(msgs: Sequence[tuple[int, Any]], time_source: str) -> list[int]:
    """Sorted stamps (ns) a run synchronises ``msgs`` (record time, message) on: header stamps (record time for
    messages without a header) with ``time_source = "header"``, record times with ``"bag"``."""
    if time_source == "bag":
        return sorted(bt for bt, _ in msgs)
    return sorted(bt if (s := header_stamp_ns(m)) is None else s for bt, m in msgs)


def _sync_gap_s(driver: Sequence[int], other: Sequence[int]) -> float | None:
    """95th percentile (s) of the time from each driver stamp inside ``other``'s span to the nearest of ``other``
    (both sorted, ns); None when no driver stamp falls in that span."""
    if not other:
        return None
    gaps = []
    for t in driver:
        if other[0] <= t <= other[-1]:
            k = bisect.bisect_left(other, t)
            gaps.append(min(abs(other[j] - t) for j in (k - 1, k) if 0 <= j < len(other)))
    if not gaps:
        return None
    gaps.sort()
    return gaps[round(0.95 * (len(gaps) - 1))] / 1e9


def _relate_to_driver(
    lasers: Sequence[LaserInfo],
    driver: str,
    tf: TfBuffer,
    stamps: dict[str, list[int]],
    *,
    base: str,
    odometry: bool,
    warnings: list[str],
) -> list[LaserInfo]:
    """Each laser with its TF mount in the driver's frame and its sync gap to the driver (see :class:`LaserInfo`);
    a warning per laser that TF does not connect to the driver (and, with odometry, the driver to ``base``)."""
    drv = next(li for li in lasers if li.topic == driver)
    out = []
    for li in lasers:
        mount: tuple[float, float, float] | None = None
        if li.frame_id == drv.frame_id or not li.frame_id:
            mount = (0.0, 0.0, 0.0)
        elif drv.frame_id:
            try:
                p = tf.lookup(drv.frame_id, li.frame_id)
                mount = (p.x, p.y, p.yaw)
            except TfLookupError:
                warnings.append(
                    f"NO TF connects {li.topic} (frame {li.frame_id!r}) to the driver's frame {drv.frame_id!r}: "
                    "the starter config assumes its mount in [mounts]; measure it"
                )
        gap = None if li.topic == driver else _sync_gap_s(stamps.get(driver, []), stamps.get(li.topic, []))
        out.append(replace(li, mount_in_driver=mount, sync_gap_s=gap))
    if odometry and drv.mount_in_base is None and drv.frame_id and drv.frame_id != base:
        warnings.append(
            f"NO TF connects the driver's frame {drv.frame_id!r} to the base frame {base!r}: the starter config "
            "assumes its mount in [mounts]; measure it"
        )
    return out


def _wrap(text: str) -> list[str]:
    """``text`` in lines of at most 110 characters (a starter config's comments)."""
    return textwrap.wrap(text, 110)


def _fmt(v: float | None, spec: str = ".2f") -> str:
    return "-" if v is None else format(v, spec)


def _topic_lines(report: BagReport) -> list[str]:
    """The topic table, its name and type columns as wide as their longest entry (at least 32 and 36)."""
    wt = max([32, *(len(t.topic) for t in report.topics)])
    wy = max([36, *(len(t.msgtype) for t in report.topics)])
    head = f"{'count':>7} {'rate Hz':>8} {'hdr Hz':>8} {'hdr-rec s':>10}  frame ids"
    lines = [f"{'topic':<{wt}} {'type':<{wy}} {head}"]
    for t in report.topics:
        ids = ", ".join(t.frame_ids) if t.frame_ids else "(no header)"
        lines.append(
            f"{t.topic:<{wt}} {t.msgtype:<{wy}} {t.count:>7} {_fmt(t.rate_hz):>8} {_fmt(t.header_rate_hz):>8} "
            f"{_fmt(t.header_offset_s, '.3f'):>10}  {ids}"
        )
    return lines


def _tf_lines(report: BagReport) -> list[str]:
    """The TF tree, an edge a line."""
    if not report.tf:
        return ["TF: none (no /tf or /tf_static messages)"]
    lines = ["TF tree (2-D: x, y in m, yaw in deg; latest transform per edge):"]
    for e in report.tf:
        kind = "static" if e.static else f"dynamic, {e.count} msgs"
        lines.append(f"  {e.parent} -> {e.child}: x={e.x:.3f} y={e.y:.3f} yaw={math.degrees(e.yaw):.1f} ({kind})")
    return lines


def _laser_line(li: LaserInfo, driver: str | None) -> str:
    """One LaserScan topic's geometry and placement."""
    sign = {1: "+ (CCW)", -1: "- (CW: reversed or upside down)", 0: "0"}[li.increment_sign]
    mount = (
        f"; in base: x={li.mount_in_base[0]:.3f} y={li.mount_in_base[1]:.3f} "
        f"yaw={math.degrees(li.mount_in_base[2]):.1f} deg"
        if li.mount_in_base is not None
        else ""
    )
    if li.topic != driver and li.mount_in_driver is not None:
        x, y, yaw = li.mount_in_driver
        mount += f"; in the driver's frame: x={x:.3f} y={y:.3f} yaw={math.degrees(yaw):.1f} deg"
    elif li.topic != driver:
        mount += "; NO TF to the driver's frame"
    if li.sync_gap_s is not None:
        mount += f"; {li.sync_gap_s:.3f} s from the driver's scans (95th percentile)"
    return (
        f"LaserScan {li.topic} (frame {li.frame_id or '?'}): FOV {li.angle_min_deg:.1f} .. "
        f"{li.angle_max_deg:.1f} deg, {li.beams} beams, increment {li.angle_increment_deg:.4f} deg "
        f"[sign {sign}], range {li.range_min_m:g} .. {li.range_max_m:g} m"
        + (" [geometry varies]" if li.varies else "")
        + mount
    )


def format_report(report: BagReport) -> str:
    """The report as human-readable text (tables)."""
    lines = [
        f"bag: {report.bag} ({report.storage})",
        f"time span: {report.duration_s:.3f} s (record times {report.start_ns} .. {report.end_ns} ns)",
        "",
        *_topic_lines(report),
        "",
        *_tf_lines(report),
        "",
        *(_laser_line(li, report.driver) for li in report.lasers),
    ]
    if not report.lasers:
        lines.append("LaserScan: none")
    for o in report.odometry:
        lines.append(
            f"odometry {o.topic}: frame {o.frame_id} -> child {o.child_frame_id}, {o.count} msgs, {_fmt(o.rate_hz)} Hz"
        )
    if not report.odometry:
        lines.append(f"odometry: none (no nav_msgs/Odometry topic): {NO_ODOMETRY}")
    lines.append("")
    lines.append(f"suggested driver: {report.driver or '-'}; time source: {report.time_source}")
    for w in report.warnings:
        lines.append(f"warning: {w}")
    return "\n".join(lines)


def _q(s: str) -> str:
    return json.dumps(s)  # a TOML basic string for plain text


#: The built-in detectors a starter configuration puts on a laser: (name, kind, what it is).
LASER_DETECTORS: tuple[tuple[str, str, str], ...] = (
    ("laser_legs", "leg", "leg detector (segments paired into people)"),
    ("laser_boosted", "boosted", "boosted segment classifier (pfpeople/models/boosted_legs.yml)"),
    ("laser_single_legs", "single-legs", "single legs the boosted classifier cannot pair, a detector of their own"),
)

#: Detectors a starter configuration offers commented out (opt-in), where the laser suits them
#: (:func:`laser_suits`): the learned detector finds more of the people with few returns on them but, in clutter
#: unlike its training data, false people the default must not have (docs/learned_detector.md).
OPT_IN_DETECTORS: tuple[tuple[str, str, str], ...] = (("laser_learned", "learned", "learned whole-scan detector"),)


def _trained_resolutions() -> tuple[float, float]:
    """The smallest and largest angle between beams (deg) of the lasers the shipped learned model was trained on
    (its model card's ``lasers``, read as a file: the detectors are not imported here)."""
    card = json.loads(resources.files("pfpeople.models").joinpath("learned_people.json").read_text(encoding="utf-8"))
    res = [float(e["resolution_deg"]) for e in card.get("lasers", []) if "resolution_deg" in e]
    if not res:
        raise ValueError("the shipped learned model's card lists no lasers (resolution_deg)")
    return min(res), max(res)


def laser_suits(kind: str, li: LaserInfo) -> str:
    """Why a detector ``kind`` does not suit the laser ``li`` ("" when it does): the learned detector needs beams as
    far apart as those its shipped model was trained on (its model card's ``lasers``, within a factor 1.5)."""
    if kind != "learned":
        return ""
    lo, hi = _trained_resolutions()
    res = abs(li.angle_increment_deg)
    if lo / 1.5 <= res <= hi * 1.5:
        return ""
    return (
        f"its beams are {res:.3f} deg apart; the shipped model was trained on {lo:.2f}-{hi:.2f} deg "
        "(pfpeople train-detector --kind learned trains one for this laser)"
    )


def starter_config(report: BagReport, *, driver: str | None = None, opt_in: bool = False) -> str:
    """TOML text of a starter run configuration for the inspected bag (see the module docstring).

    Every LaserScan topic gets the detectors of :data:`LASER_DETECTORS`: the driver's named as listed, each
    other laser's named ``NAME_TOPIC`` (``laser_legs_rear_scan``). A laser placed by TF (the pipeline looks its
    mount up in the grid frame, :mod:`pfpeople.pipeline.sensor_setup`) needs no entry; one that TF does not connect to
    the driver's frame gets a ``[mounts]`` entry at the base origin, flagged "measure it".

    Parameters
    ----------
    report : BagReport
        From :func:`inspect_bag`.
    driver : str, optional
        LaserScan topic to drive the frames (default: ``report.driver``).
    opt_in : bool
        Write the :data:`OPT_IN_DETECTORS` that suit a laser active rather than commented out.

    Returns
    -------
    str
        The configuration (TOML), which :func:`pfpeople.config.load_config` reads.

    Raises
    ------
    ValueError
        When the bag has no LaserScan topic (or ``driver`` is not one of them).
    """
    lasers = {li.topic: li for li in report.lasers}
    driver = driver or report.driver
    if driver is None or driver not in lasers:
        have = sorted(lasers) or "none"
        raise ValueError(
            f"bag {report.bag!r}: cannot write a config: driver {driver!r} is not a LaserScan topic; "
            f"LaserScan topics: {have}"
        )
    order = [lasers[driver], *(lasers[t] for t in sorted(lasers) if t != driver)]
    tf = TfBuffer()
    for e in report.tf:
        tf.set_transform(e.parent, e.child, Pose2D(x=e.x, y=e.y, yaw=e.yaw))
    mounts = _assumed_mounts(report, order, tf)
    out = [
        f"# Starter configuration written by `pfpeople inspect` for {report.bag}",
        "# (every key: docs/configuration.md). Use it with: pfpeople run BAG --config THIS_FILE",
        "# No [grid] and no [filter] table: the product's defaults apply (the grid covers every laser's view).",
        "",
        *_frames_lines(report, order, mounts),
        *_odometry_lines(report),
        *_mounts_lines(report, mounts),
    ]
    for li in order:
        out += _laser_detector_lines(report, li, order[0], tf, li.frame_id in mounts, opt_in)
    if report.warnings:
        out += ["", "# Warnings from inspect:"] + [f"#   {w}" for w in report.warnings]
    return "\n".join(out) + "\n"


def _base_frame(report: BagReport) -> str:
    """The robot's body frame of a starter config: the odometry's child frame, else ``base_link``."""
    if report.odometry:
        return max(report.odometry, key=lambda o: o.count).child_frame_id or "base_link"
    return "base_link"


def _tf_root(parents: dict[str, str], frame: str) -> str:
    """The root of ``frame``'s TF tree (``parents``: child -> parent)."""
    seen = {frame}
    while frame in parents and parents[frame] not in seen:
        frame = parents[frame]
        seen.add(frame)
    return frame


def _assumed_mounts(report: BagReport, order: Sequence[LaserInfo], tf: TfBuffer) -> dict[str, str]:
    """The frames a starter config must mount in ``[mounts]`` (frame -> why), ``order[0]`` the driver.

    A ``[mounts]`` entry is a static parent (the base frame) for a frame without TF, so it goes on the root of
    the frame's TF tree (a frame that has a TF parent would ignore it). Needed: with odometry, for the driver's
    tree when TF does not connect it to the base frame; for each other laser that TF does not connect to the
    driver's frame, for its tree and the driver's, whichever are not the base frame's.
    """
    parents = {e.child: e.parent for e in report.tf}
    base = _base_frame(report)
    base_root = _tf_root(parents, base)
    drv = order[0]
    if not drv.frame_id:
        return {}  # the run needs [frames] grid_frame; nothing can be placed relative to the driver
    drv_root = _tf_root(parents, drv.frame_id)
    unplaced: list[LaserInfo] = []
    for li in order[1:]:
        if li.frame_id and li.frame_id != drv.frame_id:
            try:
                tf.lookup(drv.frame_id, li.frame_id)
            except TfLookupError:
                unplaced.append(li)
    need: dict[str, str] = {}
    if drv_root != base_root:
        if report.odometry:
            need[drv_root] = f"the laser to the base frame {base!r} (driver {drv.topic}, frame {drv.frame_id!r})"
        elif unplaced:
            need[drv_root] = (
                f"the driver's frame {drv.frame_id!r} to the base frame {base!r}, through which the other lasers "
                "are placed"
            )
    for li in unplaced:
        root = _tf_root(parents, li.frame_id)
        if root != base_root:
            need.setdefault(root, f"{li.topic} (frame {li.frame_id!r}) to the driver's frame {drv.frame_id!r}")
    return need


def _frames_lines(report: BagReport, order: Sequence[LaserInfo], mounts: dict[str, str]) -> list[str]:
    """The ``[frames]`` table: driver, time source, a sync tolerance covering the other lasers, base frame."""
    counts = {t.topic: t for t in report.topics}
    driver = order[0].topic
    drv = counts[driver]
    out = [
        "[frames]",
        f"# The LaserScan topic with the most messages ({drv.count}, {_fmt(drv.rate_hz)} Hz) makes the frames.",
    ]
    if len(order) > 1:
        out.append("# The other LaserScan topics, each with the same detectors (named NAME_TOPIC), join its frames:")
        for li in order[1:]:
            t = counts[li.topic]
            out.append(f"#   {li.topic}: {t.count} msgs, {_fmt(t.rate_hz)} Hz, frame {li.frame_id!r}")
    out.append(f"driver = {_q(driver)}")
    off = drv.header_offset_s
    if drv.record_burst:
        out.append(
            f"# Recorded in a burst ({_fmt(drv.rate_hz)} Hz of record time, {_fmt(drv.header_rate_hz)} Hz of header "
            "stamps): the record times carry no timing;"
        )
        out.append("# synchronise on header stamps.")
    elif report.time_source == "bag":
        out.append(f"# Header stamps are {off:.3f} s (median) from the record times (> {TIME_SOURCE_THRESHOLD_S:g} s):")
        out.append("# synchronise on bag (record) time.")
    else:
        what = "no header stamps" if off is None else f"header stamps within {abs(off):.3f} s of the record times"
        out.append(f"# {what}: synchronise on header stamps.")
    out.append(f"time_source = {_q(report.time_source)}")
    if driver == report.driver:
        out += _sync_tolerance_lines(report, order)
    base = _base_frame(report)
    if report.odometry:
        odom = max(report.odometry, key=lambda o: o.count)
        out.append(f"# The robot's body frame: the child frame of the odometry ({odom.topic}).")
        out.append(f"base_frame = {_q(base)}")
    elif mounts:
        out.append("# The robot's body frame, in which the [mounts] below are given (no odometry moves it).")
        out.append(f"base_frame = {_q(base)}")
    return out


def _sync_tolerance_lines(report: BagReport, order: Sequence[LaserInfo]) -> list[str]:
    """``sync_tolerance_s`` when another laser's scans lie further from the driver's than the run's default:
    1.25 x its sync gap (:attr:`LaserInfo.sync_gap_s`), rounded up to 1 ms, at most half the driver's period."""
    gaps = [(li.sync_gap_s, li.topic) for li in order[1:] if li.sync_gap_s is not None]
    if not gaps or max(gaps)[0] * 1.25 <= SYNC_TOLERANCE_S:
        return []
    gap, topic = max(gaps)
    drv = {t.topic: t for t in report.topics}[order[0].topic]
    rate = drv.header_rate_hz if report.time_source == "header" else drv.rate_hz
    half = math.inf if not rate else 0.5 / rate
    tol = min(math.ceil(gap * 1.25 * 1000) / 1000, math.floor(half * 1000) / 1000)
    out = [
        f"# {topic}'s scans are {gap:.3f} s (95th percentile) from the driver's; with a 25 % margin for jitter",
        f"# ({gap * 1.25:.3f} s) that is more than the default tolerance ({SYNC_TOLERANCE_S:g} s), and a scan further",
        "# than sync_tolerance_s from a frame is not used.",
    ]
    if gap > half:
        out.append("# Half the driver's period is the most that pairs each frame with its own scan: some frames")
        out.append(f"# will have no {topic} scan.")
    return [*out, f"sync_tolerance_s = {tol!r}"]


def _odometry_lines(report: BagReport) -> list[str]:
    """The ``[odometry]`` table (the topic with the most messages), or a comment that there is none."""
    if not report.odometry:
        return ["", "# No nav_msgs/Odometry topic (no [odometry] table):", *(f"# {w}" for w in _wrap(NO_ODOMETRY))]
    odom = max(report.odometry, key=lambda o: o.count)
    out = [
        "",
        "[odometry]",
        f"# nav_msgs/Odometry: {odom.count} msgs, {_fmt(odom.rate_hz)} Hz, {odom.frame_id} -> {odom.child_frame_id}.",
    ]
    if len(report.odometry) > 1:
        out.append("# Other odometry topics: " + ", ".join(o.topic for o in report.odometry if o is not odom))
    return [*out, f"topic = {_q(odom.topic)}"]


def _mounts_lines(report: BagReport, mounts: dict[str, str]) -> list[str]:
    """The ``[mounts]`` table of the frames TF does not place: each at the base origin, flagged."""
    if not mounts:
        return []
    out = ["", "[mounts]"]
    for frame, why in mounts.items():
        out += [
            f"# NO TF connects {why}: measure it.",
            f"# {frame!r} is ASSUMED at the base origin, facing forward; edit to its [x, y, yaw] in base_frame",
            f"# {_base_frame(report)!r} (m, m, rad).",
            f"{_q(frame)} = [0.0, 0.0, 0.0]",
        ]
    return out


def _model_lines(li: LaserInfo) -> list[str]:
    """A laser detector's ``[detectors.model]``: the scan's field of view (rounded outwards) and range."""
    model = [
        "[detectors.model]",
        f"# Field of view (rad, laser frame, rounded outwards): beams from {math.degrees(li.fov_min_rad):.2f} to "
        f"{math.degrees(li.fov_max_rad):.2f} deg ({li.beams} beams).",
        f"fov_min = {max(math.floor(li.fov_min_rad * 1e5) / 1e5, -math.pi)!r}",
        f"fov_max = {min(math.ceil(li.fov_max_rad * 1e5) / 1e5, math.pi)!r}",
    ]
    if math.isfinite(li.range_max_m) and li.range_max_m > 0:
        return [*model, "# The scan's range_max (m).", f"max_range = {round(li.range_max_m, 3)!r}"]
    return [*model, f"# range_max = {li.range_max_m} is not a usable range: no max_range (unbounded)."]


def laser_detector_name(name: str, topic: str, driver: str) -> str:
    """Name of detector ``name`` of :data:`LASER_DETECTORS` on ``topic`` in a starter config: ``name`` on the
    driver, ``name_TOPIC`` on every other laser (the topic without its leading slash, every character but
    ``[A-Za-z0-9_]`` as ``_``: a valid ROS name, e.g. ``laser_legs_robot_rear_scan`` for ``/robot/rear_scan``)."""
    return name if topic == driver else f"{name}_{re.sub(r'[^A-Za-z0-9_]', '_', topic.lstrip('/'))}"


def _laser_detector_lines(
    report: BagReport, li: LaserInfo, drv: LaserInfo, tf: TfBuffer, assumed: bool, opt_in: bool
) -> list[str]:
    """The :data:`LASER_DETECTORS` of one laser, after a comment on where the run places it, and its
    :data:`OPT_IN_DETECTORS` (commented out unless ``opt_in``)."""
    out = [""]
    if li.topic == drv.topic:
        where = "on the driving scan"
    else:
        where = f"on {li.topic}"
        head = f"# {li.topic} (frame {li.frame_id!r})"
        try:
            p = tf.lookup(drv.frame_id, li.frame_id) if li.frame_id and drv.frame_id else Pose2D()
            out += [
                f"{head}: placed by TF at x={p.x:.3f} m, y={p.y:.3f} m, yaw={math.degrees(p.yaw):.1f} deg",
                f"# in the driver's frame {drv.frame_id!r}.",
            ]
        except TfLookupError:
            what = "entry" if assumed else "entries"
            out += [
                f"{head}: NO TF connects it to the driver's frame {drv.frame_id!r};",
                f"# placed by the [mounts] {what} above (measure it).",
            ]
    model = _model_lines(li)
    for name, kind, what in LASER_DETECTORS:
        out += [*_detector_block(name, kind, f"# Built-in {what} {where}.", li, drv.topic, model), ""]
    for name, kind, what in OPT_IN_DETECTORS:
        full = laser_detector_name(name, li.topic, drv.topic)
        why_not = laser_suits(kind, li)
        if why_not:
            out += [f"# {full} ({kind}, opt-in) does not suit this laser: {why_not}.", ""]
            continue
        if opt_in:
            note = f"# Opt-in (written by --opt-in): the {what} {where} (docs/learned_detector.md)."
            out += [*_detector_block(name, kind, note, li, drv.topic, model), ""]
            continue
        note = f"# Opt-in, uncomment to fuse it: the {what} {where} (docs/learned_detector.md)."
        block = _detector_block(name, kind, note, li, drv.topic, model)
        out += [block[1], *(f"# {line}" for line in block[:1] + block[2:]), ""]
    return out[:-1]


def _detector_block(name: str, kind: str, note: str, li: LaserInfo, driver: str, model: list[str]) -> list[str]:
    """The ``[[detectors]]`` table of a detector ``kind`` on the laser ``li``, after its comment line ``note``."""
    return [
        "[[detectors]]",
        note,
        f"name = {_q(laser_detector_name(name, li.topic, driver))}",
        f"kind = {_q(kind)}",
        f"topic = {_q(li.topic)}",
        *model,
    ]


def inspect_path(path: str | Path | Sequence[str | Path], *, sample: int = 200) -> BagReport:
    """Open a bag path (see :class:`BagSource`) and inspect it."""
    with BagSource(path) as bag:
        return inspect_bag(bag, sample=sample, name=str(path) if isinstance(path, str | Path) else None)
