"""A small 2-D TF buffer: the planar projection (x, y, yaw) of ``/tf`` and ``/tf_static`` transforms.

Each ``geometry_msgs/TransformStamped`` gives the pose of ``child_frame_id`` in ``header.frame_id``. We keep
the latest transform per child (static ones are never overwritten by dynamic ones of the same child unless
newer; a child given a second parent is refused, naming both, as a tree has one parent per frame) and project
it to the plane: x, y of the translation and the yaw of the rotation,

    yaw = atan2(2 (w z + x y), 1 - 2 (y^2 + z^2))            (ZYX Euler angles, REP-103),

which is exact for mounts rotated about the vertical axis only. A mount with roll or pitch (e.g. a camera
optical frame) has no exact planar form; configure the detector's ``frame`` to a level frame instead.
Static fallbacks (``[mounts]`` in the run config) give frames the bag has no TF for.

A run reads its mounts before the first frame and then follows TF over time (:class:`MountFollower`): the
transforms read along the frames are applied at their stamps, and each frame's detectors are placed with the
mount composed of every edge's latest transform stamped at or before the frame (latest-before, not
interpolated). :class:`MountWatch` checks the TF edges the mounts are made of and reports every transform more
than :data:`MOUNT_CHANGE_M` or :data:`MOUNT_CHANGE_RAD` off the value read before the run (a panning or moving
mount).
"""

from __future__ import annotations

import copy
import heapq
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from gridbridge.geometry import (
    MIN_QUATERNION_NORM,
    Pose2D,
    xy_from_translation,
    yaw_from_orientation,
    yaw_from_quaternion,
)

__all__ = [
    "MOUNT_CHANGE_M",
    "MOUNT_CHANGE_RAD",
    "MountChange",
    "MountFollower",
    "MountWatch",
    "TfBuffer",
    "TfLink",
    "TfLookupError",
    "yaw_from_quaternion",
]

#: A mount's TF moving more than this (m) or turning more than :data:`MOUNT_CHANGE_RAD` (rad) from the value a
#: run uses is a moving mount: below both, a detection 5 m away moves by under 6 cm (a fifth of a 0.3 m cell),
#: the size of TF publishers' rounding and calibration jitter.
MOUNT_CHANGE_M = 0.01
#: See :data:`MOUNT_CHANGE_M`.
MOUNT_CHANGE_RAD = 0.01


class TfLookupError(LookupError):
    """No chain of transforms connects two frames."""


@dataclass(frozen=True)
class TfLink:
    """One transform of the tree: ``pose`` of ``child`` in ``parent``, from ``topic`` (``""``: set directly)."""

    parent: str
    child: str
    pose: Pose2D
    topic: str

    @property
    def name(self) -> str:
        """``"parent -> child"``."""
        return f"{self.parent} -> {self.child}"


class TfBuffer:
    """Latest 2-D transform of every child frame, and look-ups along the tree.

    Parameters
    ----------
    fallback_parent : str
        Parent frame of the ``fallback`` mounts (the robot's base frame).
    fallback : mapping of str to (x, y, yaw)
        Static mounts of child frames in ``fallback_parent``, used for frames without TF.
    """

    def __init__(
        self, *, fallback_parent: str = "base_link", fallback: Mapping[str, tuple[float, float, float]] = {}
    ) -> None:
        self._parent: dict[str, tuple[str, Pose2D, int]] = {}
        #: The topic each child's transform came from (``""``: set directly).
        self._topic: dict[str, str] = {}
        #: Children whose transform is still a ``[mounts]`` fallback (TF replaces it, whatever its parent).
        self._fallback: set[str] = set()
        for child, (x, y, yaw) in dict(fallback).items():
            self._parent[child.lstrip("/")] = (fallback_parent.lstrip("/"), Pose2D(x=x, y=y, yaw=yaw), -1)
            self._fallback.add(child.lstrip("/"))

    def set_transform(self, parent: str, child: str, pose: Pose2D, stamp_ns: int = 0, *, topic: str = "") -> None:
        """Record ``pose`` of ``child`` in ``parent`` (leading slashes are ignored, as tf2 does).

        Raises
        ------
        ValueError
            If a frame is empty or its own parent, or ``child`` already has another parent in TF (a tree has
            one parent per frame): the message names the frame, both parents and their topics.
        """
        parent, child = parent.lstrip("/"), child.lstrip("/")
        if not parent or not child:
            raise ValueError(f"TF transform needs non-empty frames, got parent={parent!r} child={child!r}")
        if parent == child:
            raise ValueError(f"TF transform from frame {parent!r} to itself")
        old = self._parent.get(child)
        if old is not None and old[0] != parent and child not in self._fallback:
            raise ValueError(
                f"TF frame {child!r} has two parents: {old[0]!r} (topic {self._topic.get(child, '')!r}) and "
                f"{parent!r} (topic {topic!r}); a TF tree has one parent per frame (fix the publishers, or leave "
                "one TF topic out of [tf] topics and give its mounts in [mounts])"
            )
        if old is None or old[2] <= stamp_ns or child in self._fallback:
            self._parent[child] = (parent, pose, stamp_ns)
            self._topic[child] = topic
            self._fallback.discard(child)

    def add_message(self, msg: object, *, topic: str = "/tf", new_frames_only: bool = False) -> int:
        """Add every transform of a ``tf2_msgs/TFMessage`` read on ``topic``; returns how many were added.

        With ``new_frames_only``, only transforms of children the buffer has no TF for (a ``[mounts]`` fallback
        counts as none) are added.

        Raises
        ------
        ValueError
            Not a TFMessage, a transform whose rotation is a zero (or non-finite) quaternion, which would read
            as yaw 0, or whose translation is not finite: the message names the topic and the transform. A
            frame given a second parent (:meth:`set_transform`).
        """
        transforms = getattr(msg, "transforms", None)
        if transforms is None:
            raise ValueError(f"topic {topic!r}: not a tf2_msgs/TFMessage: {type(msg).__name__} has no 'transforms'")
        added = []
        for t in transforms:
            child = str(t.child_frame_id).lstrip("/")
            if new_frames_only and child in self._parent and child not in self._fallback:
                continue
            tr, q = t.transform.translation, t.transform.rotation
            stamp = int(t.header.stamp.sec) * 1_000_000_000 + int(t.header.stamp.nanosec)
            where = f"topic {topic!r}: transform {t.header.frame_id!s} -> {t.child_frame_id!s}"
            x, y = xy_from_translation(tr.x, tr.y, tr.z, where)
            pose = Pose2D(x=x, y=y, yaw=yaw_from_orientation(q.x, q.y, q.z, q.w, where))
            self.set_transform(t.header.frame_id, t.child_frame_id, pose, stamp, topic=topic)
            added.append(child)
        return len(added)

    def parent_of(self, child: str) -> str | None:
        """The TF parent of ``child`` (None: no TF for it; a ``[mounts]`` fallback is none)."""
        child = child.lstrip("/")
        if child in self._fallback or child not in self._parent:
            return None
        return self._parent[child][0]

    @property
    def frames(self) -> list[str]:
        """All frames known (children and parents)."""
        out = set(self._parent)
        out.update(p for p, _, _ in self._parent.values())
        return sorted(out)

    def _to_root(self, frame: str) -> tuple[str, Pose2D]:
        pose = Pose2D()
        seen = {frame}
        while frame in self._parent:
            parent, p, _ = self._parent[frame]
            pose = p.compose(pose)
            frame = parent
            if frame in seen:
                raise TfLookupError(f"TF cycle through frame {frame!r}")
            seen.add(frame)
        return frame, pose

    def edges(self, target: str, source: str) -> list[TfLink]:
        """The TF transforms :meth:`lookup` composes for ``target``, ``source`` (``[mounts]`` fallbacks left out).

        Only the edges below the frames' lowest common ancestor: e.g. ``odom -> base_link`` above both is not
        one (it cancels). Empty when the frames are the same or not connected.
        """
        target, source = target.lstrip("/"), source.lstrip("/")
        up_t, up_s = self._chain(target), self._chain(source)
        if up_t[-1] != up_s[-1]:
            return []
        common = set(up_t) & set(up_s)
        below = [f for f in up_t if f not in common] + [f for f in up_s if f not in common]
        return [
            TfLink(self._parent[f][0], f, self._parent[f][1], self._topic.get(f, ""))
            for f in below
            if f not in self._fallback
        ]

    def fallback_links(self, frames: Iterable[str]) -> list[TfLink]:
        """The ``[mounts]`` fallbacks that place ``frames``: the fallback edges on the way from each frame to the
        root of its tree (parent: the fallback parent, the base frame), each once, in the order met.

        These are the transforms a run took from its configuration because TF had none: a result bag writes them
        on ``/tf_static`` so that every frame the run placed is placed in the bag too.
        """
        out: dict[str, TfLink] = {}
        for frame in frames:
            for f in self._chain(frame.lstrip("/"))[:-1]:
                if f in self._fallback and f not in out:
                    parent, pose, _ = self._parent[f]
                    out[f] = TfLink(parent, f, pose, "")
        return list(out.values())

    def _chain(self, frame: str) -> list[str]:
        """``frame`` and its ancestors up to the root (the tree has no cycle: :meth:`_to_root`)."""
        self._to_root(frame)
        out = [frame]
        while out[-1] in self._parent:
            out.append(self._parent[out[-1]][0])
        return out

    def lookup(self, target: str, source: str) -> Pose2D:
        """Pose of frame ``source`` in frame ``target`` (maps ``source`` points to ``target`` with ``apply``).

        Raises
        ------
        TfLookupError
            When the two frames are not connected; the message lists the known frames.
        """
        target, source = target.lstrip("/"), source.lstrip("/")
        if target == source:
            return Pose2D()
        root_t, pose_t = self._to_root(target)
        root_s, pose_s = self._to_root(source)
        if root_t != root_s:
            raise TfLookupError(
                f"no transform from frame {source!r} to frame {target!r}; known frames: {self.frames} "
                "(add TF to the bag or a static mount in the config's [mounts] table)"
            )
        return pose_t.inverse().compose(pose_s)

    def can_transform(self, target: str, source: str) -> bool:
        try:
            self.lookup(target, source)
        except TfLookupError:
            return False
        return True


@dataclass(frozen=True)
class MountChange:
    """A transform of a watched edge off the value a run uses (:class:`MountWatch`)."""

    edge: TfLink
    pose: Pose2D
    stamp_ns: int
    distance_m: float
    turn_rad: float


class MountWatch:
    """Finds the transforms of a run's mount edges that differ from the values the run uses.

    Parameters
    ----------
    edges : iterable of TfLink
        The edges the run's mounts are made of, each with the value used (:meth:`TfBuffer.edges`); edges
        without a topic are not watched.
    tol_m, tol_rad : float
        A transform moved more than ``tol_m`` (m) or turned more than ``tol_rad`` (rad) is a change.
    """

    def __init__(self, edges: Iterable[TfLink], *, tol_m: float = MOUNT_CHANGE_M, tol_rad: float = MOUNT_CHANGE_RAD):
        self.edges = {(e.parent, e.child): e for e in edges if e.topic}
        self.tol_m, self.tol_rad = tol_m, tol_rad
        self._topics = sorted({e.topic for e in self.edges.values()})

    @property
    def topics(self) -> list[str]:
        """The TF topics the watched edges came from (sorted; kept from the construction: the run asks at every TF
        message)."""
        return self._topics

    def check(self, msg: object) -> list[MountChange]:
        """The transforms of a ``tf2_msgs/TFMessage`` that change a watched edge (others are ignored)."""
        out = []
        for t in getattr(msg, "transforms", None) or []:
            edge = self.edges.get((str(t.header.frame_id).lstrip("/"), str(t.child_frame_id).lstrip("/")))
            if edge is None:
                continue
            tr, q = t.transform.translation, t.transform.rotation
            try:
                x, y = xy_from_translation(tr.x, tr.y, tr.z, edge.name)
                pose = Pose2D(x=x, y=y, yaw=yaw_from_orientation(q.x, q.y, q.z, q.w, edge.name))
            except ValueError:
                continue  # a broken transform of the edge is not a value the run could have used
            dist = math.hypot(pose.x - edge.pose.x, pose.y - edge.pose.y)
            turn = math.atan2(math.sin(pose.yaw - edge.pose.yaw), math.cos(pose.yaw - edge.pose.yaw))
            if dist > self.tol_m or abs(turn) > self.tol_rad:
                stamp = int(t.header.stamp.sec) * 1_000_000_000 + int(t.header.stamp.nanosec)
                out.append(MountChange(edge, pose, stamp, dist, turn))
        return out


def _planar_pose(tr: Any, q: Any) -> Pose2D | None:
    """The pose of a transform's translation ``tr`` and rotation ``q`` (message fields), or None where
    :func:`gridbridge.geometry.xy_from_translation` or :func:`~gridbridge.geometry.yaw_from_orientation` would
    refuse it (a non-finite translation, a non-finite or zero quaternion): their checks and floats, without
    building the error texts nobody reads here."""
    x, y, z = float(tr.x), float(tr.y), float(tr.z)
    qx, qy, qz, qw = float(q.x), float(q.y), float(q.z), float(q.w)
    isfinite = math.isfinite
    if not (isfinite(x) and isfinite(y) and isfinite(z)):
        return None
    if not (isfinite(qx) and isfinite(qy) and isfinite(qz) and isfinite(qw)):
        return None
    if math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw) < MIN_QUATERNION_NORM:
        return None
    return Pose2D(x=x, y=y, yaw=yaw_from_quaternion(qx, qy, qz, qw))


def _transforms(msg: object) -> Iterable[tuple[int, str, str, Pose2D | None]]:
    """``(stamp_ns, parent, child, pose)`` of every transform of a TFMessage; ``pose`` None for a broken one (a
    non-finite translation, a zero or non-finite quaternion: the run refuses them before it starts,
    :meth:`TfBuffer.add_message`; one appearing later is not a usable mount, counted by the caller)."""
    for t in getattr(msg, "transforms", None) or []:
        pose = _planar_pose(t.transform.translation, t.transform.rotation)
        parent, child = str(t.header.frame_id).lstrip("/"), str(t.child_frame_id).lstrip("/")
        yield int(t.header.stamp.sec) * 1_000_000_000 + int(t.header.stamp.nanosec), parent, child, pose


class MountFollower:
    """Mounts followed over TF time: each frame's mount from every edge's latest transform at or before its stamp.

    Parameters
    ----------
    tf : TfBuffer
        The transforms read before the run (copied: the run's setup keeps its own).
    grid_frame : str
        The frame mounts are given in.
    frames : iterable of str, optional
        The frames whose mounts will be asked for: only the transforms of their chains to the root (and of frames
        the tree does not know yet) are kept. None: every transform.
    max_pending : int
        Transforms kept waiting for a frame at or after their stamp; beyond it the oldest is applied at once.
    """

    def __init__(
        self, tf: TfBuffer, grid_frame: str, *, frames: Iterable[str] | None = None, max_pending: int = 10_000
    ) -> None:
        self.tf = copy.deepcopy(tf)
        self.grid_frame = grid_frame
        self.max_pending = max_pending
        self._pending: list[tuple[int, int, str, str, Pose2D, str]] = []
        self._seq = 0
        self._cache: dict[str, Pose2D] = {}
        #: The frames on the chains of ``frames`` and of those looked up (None: all).
        self._relevant: set[str] | None = None
        if frames is not None:
            self._relevant = set()
            for f in [grid_frame, *frames]:
                self._relevant.update(self.tf._chain(f.lstrip("/")))

    def add(self, msg: object, *, topic: str = "/tf") -> list[str]:
        """Queue the transforms of a ``tf2_msgs/TFMessage`` read during the run (applied by :meth:`advance`);
        a transform giving a known frame another parent is left out (the tree read before the run holds).

        Returns
        -------
        list of str
            The edges (``"parent -> child"``) of the message's broken transforms (a NaN or infinite translation, a
            zero or non-finite quaternion), left out: each edge keeps its last good transform.
        """
        broken = []
        for stamp, parent, child, pose in _transforms(msg):
            if pose is None:
                broken.append(f"{parent} -> {child}")
                continue
            old = self.tf.parent_of(child)
            if old is not None and (old != parent or (self._relevant is not None and child not in self._relevant)):
                continue
            self._seq += 1
            heapq.heappush(self._pending, (stamp, self._seq, parent, child, pose, topic))
            if len(self._pending) > self.max_pending:
                self._apply(heapq.heappop(self._pending))
        return broken

    def _apply(self, item: tuple[int, int, str, str, Pose2D, str]) -> None:
        stamp, _, parent, child, pose, topic = item
        self.tf.set_transform(parent, child, pose, stamp, topic=topic)
        self._cache.clear()

    def advance(self, stamp_ns: int) -> None:
        """Apply every queued transform stamped at or before ``stamp_ns``."""
        while self._pending and self._pending[0][0] <= stamp_ns:
            self._apply(heapq.heappop(self._pending))

    def mount(self, frame: str) -> Pose2D:
        """The pose of ``frame`` in the grid frame now (raises :class:`TfLookupError` when not connected)."""
        pose = self._cache.get(frame)
        if pose is None:
            pose = self._cache[frame] = self.tf.lookup(self.grid_frame, frame)
            if self._relevant is not None:
                self._relevant.update(self.tf._chain(frame.lstrip("/")))
        return pose
