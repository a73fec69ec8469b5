"""A small 2-D TF buffer: the planar projection (x, y, yaw) of ``/tf`` and ``/tf_static`` transforms.

Each ``geometry_msgs/TransformStamped`` gives the pose of ``child_frame_id`` in ``header.frame_id``. We keep
the latest transform per child (static ones are never overwritten by dynamic ones of the same child unless
newer; a child given a second parent is refused, naming both, as a tree has one parent per frame) and project
it to the plane: x, y of the translation and the yaw of the rotation,

    yaw = atan2(2 (w z + x y), 1 - 2 (y^2 + z^2))            (ZYX Euler angles, REP-103),

which is exact for mounts rotated about the vertical axis only. A mount with roll or pitch (e.g. a camera
optical frame) has no exact planar form; configure the detector's ``frame`` to a level frame instead.
Static fallbacks (``[mounts]`` in the run config) give frames the bag has no TF for.
"""

from __future__ import annotations

from collections.abc import Mapping

from gridbridge.geometry import Pose2D, xy_from_translation, yaw_from_orientation, yaw_from_quaternion

__all__ = ["TfBuffer", "TfLookupError", "yaw_from_quaternion"]


class TfLookupError(LookupError):
    """No chain of transforms connects two frames."""


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

    def add_message(self, msg: object, *, topic: str = "/tf") -> int:
        """Add every transform of a ``tf2_msgs/TFMessage`` read on ``topic``; returns how many were added.

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
        for t in transforms:
            tr, q = t.transform.translation, t.transform.rotation
            stamp = int(t.header.stamp.sec) * 1_000_000_000 + int(t.header.stamp.nanosec)
            where = f"topic {topic!r}: transform {t.header.frame_id!s} -> {t.child_frame_id!s}"
            x, y = xy_from_translation(tr.x, tr.y, tr.z, where)
            pose = Pose2D(x=x, y=y, yaw=yaw_from_orientation(q.x, q.y, q.z, q.w, where))
            self.set_transform(t.header.frame_id, t.child_frame_id, pose, stamp, topic=topic)
        return len(transforms)

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
