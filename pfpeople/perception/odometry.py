"""Ego-motion of the grid frame between frames: from odometry messages, or from laser scan matching.

The odometry pose of the base frame is interpolated to the frame stamp (linear in x, y and the wrapped yaw)
and composed with the grid frame's mount on the base (``P_grid = P_base * T_base_grid``). The relative motion
``D = P_grid(t_{k-1})^-1 P_grid(t_k)`` is converted to the constant body-frame velocity ``(v, vy, omega)`` of
the grid frame over ``dt = t_k - t_{k-1}`` that reproduces it exactly (:func:`odometry_between`; the motion
model of :func:`gridbridge.velocity_displacement`, eqs. 10-11):

    omega = dtheta / dt,   arc = (dtheta/2) / sin(dtheta/2),
    v  = arc * ( dx cos(dtheta/2) + dy sin(dtheta/2)) / dt,
    vy = arc * (-dx sin(dtheta/2) + dy cos(dtheta/2)) / dt.

The lateral part ``vy`` is what a grid frame mounted off the robot's rotation axis (and yawed) has: it is
applied by both filters; the largest lateral displacement of a step is reported in
:attr:`pfpeople.run_state.RunSummary.max_lateral_m` (informative). Without odometry in a frame the robot is
taken as standing (counted, logged once); the next frame with odometry moves the grid by the whole
displacement since the last frame that had it, so no motion is lost.

Without an odometry topic, the motion can come from the driving laser's scan matching
(:mod:`pfpeople.perception.clutter_map`, ``[clutter] laser_odometry``): :meth:`OdometryIntegrator.from_laser`.

Frame timing: the first frame uses ``dt =`` :data:`FIRST_DT_S` (the paper's step; the initial belief is
uniform, so the prediction has no effect there). A gap between frames longer than :data:`MAX_GAP_S` restarts
the filter (:attr:`EgoMotion.restarted`; counted): a prediction over a long gap would be meaningless and its
kernel very large.

Odometry jumps: a step of the grid frame faster than :data:`MAX_ODOMETRY_SPEED_MPS` or turning faster than
:data:`MAX_ODOMETRY_YAW_RATE` (judged over at least :data:`JUMP_MIN_SPAN_S`) is not motion but a reset or a
relocalisation of the odometry frame (e.g. x += 100 m, or yaw += pi, between two messages): the filter restarts
there as over a gap (:attr:`EgoMotion.restarted`; counted in ``filter_restarts`` and ``odometry_jumps``,
warned once), and the motion goes on from the new pose. The two messages bracketing a frame are not
interpolated across such a jump: the one nearer the frame stamp is used.

The odometry pose is taken as the pose of the base frame (``[frames] base_frame``, where the grid frame's mount
is looked up). Odometry messages whose ``child_frame_id`` is another frame (e.g. ``base_footprint`` while the
mounts hang from ``base_link``) are used as if they were the base frame's (exact when the two frames coincide
in the plane), warned once naming both and counted (``odometry_other_child``).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace

from gridbridge.ego_motion import Odometry
from gridbridge.geometry import Pose2D
from pfpeople.io.bag.reader import MessageDataError, odometry_pose_from_msg
from pfpeople.io.bag.sync import Frame
from pfpeople.run_state import RunSummary, WarnOnce, count

__all__ = [
    "FIRST_DT_S",
    "JUMP_MIN_SPAN_S",
    "MAX_GAP_S",
    "MAX_ODOMETRY_SPEED_MPS",
    "MAX_ODOMETRY_YAW_RATE",
    "MIN_FRAME_DT_S",
    "EgoMotion",
    "OdometryIntegrator",
    "interpolate_pose",
    "is_odometry_jump",
    "odometry_between",
]

log = logging.getLogger(__name__)

#: dt of the first frame (s).
FIRST_DT_S = 0.1
#: A gap between frames longer than this (s) restarts the filter.
MAX_GAP_S = 2.0
#: Frames closer than this (s, 250 Hz) are faster than 2-D lasers scan: the run warns (once) that its clock
#: does not time the scans (e.g. bag time of a bag written after the fact).
MIN_FRAME_DT_S = 0.004
#: A step of the grid frame faster than this (m/s) is an odometry jump, not motion: robots among people drive
#: below 2 m/s, so 5 m/s (18 km/h) leaves room for fast platforms, while a reset odometry moves metres at once.
MAX_ODOMETRY_SPEED_MPS = 5.0
#: A step turning faster than this (rad/s, a full turn a second) is an odometry jump: robot bases turn below
#: about 3 rad/s, while a flipped or relocalised heading turns by up to pi at once.
MAX_ODOMETRY_YAW_RATE = 2 * math.pi
#: Steps are judged over at least this long (s, the paper's step), so that a few centimetres of odometry noise
#: between frames (or messages) milliseconds apart are not taken for a jump.
JUMP_MIN_SPAN_S = 0.1


def interpolate_pose(a: tuple[int, Pose2D], b: tuple[int, Pose2D], t: int) -> Pose2D:
    """The pose at stamp ``t`` (ns) between ``a = (t_a, pose_a)`` and ``b``: linear in x, y and the wrapped yaw."""
    (ta, pa), (tb, pb) = a, b
    if tb == ta:
        return pb
    f = (t - ta) / (tb - ta)
    dyaw = math.atan2(math.sin(pb.yaw - pa.yaw), math.cos(pb.yaw - pa.yaw))
    return Pose2D(x=pa.x + f * (pb.x - pa.x), y=pa.y + f * (pb.y - pa.y), yaw=pa.yaw + f * dyaw)


def odometry_between(p0: Pose2D, p1: Pose2D, dt: float) -> tuple[Odometry, float]:
    """The constant body-frame velocity moving a frame from pose ``p0`` to ``p1`` in ``dt`` s (module docstring).

    ``gridbridge.ego_motion.odometry_pose(odometry, dt)`` is ``p0^-1 p1`` (to rounding), sideways motion included.

    Parameters
    ----------
    p0, p1 : Pose2D
        The frame's poses at the start and the end of the step (any common fixed frame; m, rad).
    dt : float
        Duration of the step (s, > 0).

    Returns
    -------
    odometry : Odometry
        ``v``, ``vy`` (m/s, x and y of the moving frame) and ``omega`` (rad/s).
    lateral : float
        The lateral displacement (m): the chord of the step across the mean heading ``dtheta / 2``
        (``vy dt / arc``; 0 for a frame on the rotation axis moving on an arc).
    """
    d = p0.inverse().compose(p1)
    half = 0.5 * d.yaw
    along = d.x * math.cos(half) + d.y * math.sin(half)
    lateral = -d.x * math.sin(half) + d.y * math.cos(half)
    arc = 1.0 if abs(half) < 1e-9 else half / math.sin(half)
    return Odometry(v=arc * along / dt, omega=d.yaw / dt, vy=arc * lateral / dt), lateral


def is_odometry_jump(p0: Pose2D, p1: Pose2D, span_s: float) -> bool:
    """Whether going from pose ``p0`` to ``p1`` in ``span_s`` s is an odometry jump, not motion.

    Parameters
    ----------
    p0, p1 : Pose2D
        Two poses of one frame in the odometry frame (m, rad).
    span_s : float
        Time between them (s); taken as at least :data:`JUMP_MIN_SPAN_S`.

    Returns
    -------
    bool
        True when the step is faster than :data:`MAX_ODOMETRY_SPEED_MPS` or turns faster than
        :data:`MAX_ODOMETRY_YAW_RATE`.
    """
    span = max(span_s, JUMP_MIN_SPAN_S)
    dyaw = math.atan2(math.sin(p1.yaw - p0.yaw), math.cos(p1.yaw - p0.yaw))
    dist = math.hypot(p1.x - p0.x, p1.y - p0.y)
    return dist > MAX_ODOMETRY_SPEED_MPS * span or abs(dyaw) > MAX_ODOMETRY_YAW_RATE * span


@dataclass(frozen=True, kw_only=True)
class EgoMotion:
    """The grid frame's motion into one frame.

    Attributes
    ----------
    dt : float
        Time step (s): since the previous frame, :data:`FIRST_DT_S` for the first frame and after a restart.
    first : bool
        True for the first frame of the run (no previous frame).
    restarted : bool
        True when a gap longer than :data:`MAX_GAP_S` or an odometry jump (:func:`is_odometry_jump`) preceded
        the frame (the filter restarts).
    pose : Pose2D or None
        The grid frame's odometry pose (odom frame; None: no odometry in this frame).
    ego : Pose2D or None
        The grid frame at this frame in the grid frame at the previous frame with odometry (from odometry).
    odometry : Odometry or None
        Controls of the filter's ego-motion step (m/s, rad/s); None: the robot is taken as standing.
    laser_ego : Pose2D or None
        The scan-matched motion (grid frame) when it gave :attr:`odometry` (:meth:`OdometryIntegrator.from_laser`).
    """

    dt: float
    first: bool = False
    restarted: bool = False
    pose: Pose2D | None = None
    ego: Pose2D | None = None
    odometry: Odometry | None = None
    laser_ego: Pose2D | None = None

    @property
    def motion(self) -> Pose2D | None:
        """The motion the step used, from odometry or else from scan matching (None: unknown)."""
        return self.ego if self.ego is not None else self.laser_ego


class OdometryIntegrator:
    """Frame timing and the grid frame's ego-motion, frame after frame (see the module docstring).

    Call :meth:`begin` for each frame, :meth:`from_laser` when a scan-matched motion is known, and
    :meth:`end` once the frame is processed.

    Parameters
    ----------
    topic : str or None
        The odometry topic (``nav_msgs/Odometry``); None or ``""``: no odometry (the robot stands, unless
        ``laser_odometry``).
    base_to_grid : Pose2D, optional
        The grid frame's pose in the base frame (the odometry's child frame); required with ``topic``.
    laser_odometry : bool
        Without ``topic``, take the motion from scan matching (:meth:`from_laser`).
    base_frame : str, optional
        The frame ``base_to_grid`` is given in; odometry messages of another child frame are warned about
        (once) and counted (``odometry_other_child``). None: not checked.
    summary : RunSummary, optional
        Where the counts go (``frames_without_odometry``, ``max_lateral_m``, ``laser_odometry_frames``,
        ``ego_motion``, ``filter_restarts``, ``odometry_jumps``, ``odometry_other_child``, ``bad_messages[topic]``);
        default a new one.
    warn : WarnOnce, optional
        Warn-once logger shared with the rest of the run; default a new one.

    Raises
    ------
    ValueError
        If ``topic`` is given without ``base_to_grid``.
    """

    def __init__(
        self,
        topic: str | None,
        base_to_grid: Pose2D | None = None,
        *,
        laser_odometry: bool = False,
        base_frame: str | None = None,
        summary: RunSummary | None = None,
        warn: WarnOnce | None = None,
    ) -> None:
        if topic and base_to_grid is None:
            raise ValueError(f"odometry topic {topic!r} needs base_to_grid, the grid frame's pose in the base frame")
        self.topic = topic or None
        self.base_to_grid = base_to_grid
        self.laser_odometry = laser_odometry
        self.base_frame = base_frame.lstrip("/") if base_frame else None
        self.summary = summary if summary is not None else RunSummary()
        self.warn = warn if warn is not None else WarnOnce(log)
        self.prev_stamp_ns: int | None = None
        #: The grid frame's pose in the latest frame that had odometry (None after a restart).
        self.prev_pose: Pose2D | None = None
        #: The stamp (ns) of the frame :attr:`prev_pose` is at.
        self.prev_pose_stamp_ns: int | None = None

    def reset(self) -> None:
        """Forget the previous frame (a new run)."""
        self.prev_stamp_ns = None
        self.prev_pose = None
        self.prev_pose_stamp_ns = None

    def _check_child(self, child: str) -> None:
        """Warn (once) and count an odometry message whose child frame is not :attr:`base_frame`."""
        if not self.base_frame or not child or child == self.base_frame:
            return
        self.summary.odometry_other_child += 1
        self.warn(
            "odochild",
            "topic %r: odometry child frame %r is not the base frame %r ([frames] base_frame, which the grid "
            "frame's mount is given in): the run takes the odometry pose as the pose of %r (exact only if the two "
            "frames coincide in the plane; set base_frame = %r if that is the robot's base; such messages are "
            "counted in odometry_other_child)",
            self.topic,
            child,
            self.base_frame,
            self.base_frame,
            child,
            logger=log,
        )

    def pose(self, frame: Frame) -> Pose2D | None:
        """The grid frame's odometry pose at the frame stamp (None: no usable odometry message in the frame)."""
        if not self.topic:
            return None
        poses = []
        for m in frame.inputs.get(self.topic, []):
            try:
                pose, child = odometry_pose_from_msg(m.msg, topic=m.topic)
            except MessageDataError as exc:
                count(self.summary.bad_messages, self.topic)
                self.warn("bad:odom", "%s (such messages are not used; counted)", exc, logger=log)
                return None
            self._check_child(child)
            poses.append((m.stamp_ns, pose))
        if not poses:
            return None
        if len(poses) == 1:
            base = poses[0][1]
        elif is_odometry_jump(poses[0][1], poses[1][1], (poses[1][0] - poses[0][0]) * 1e-9):
            base = min(poses, key=lambda p: abs(p[0] - frame.stamp_ns))[1]  # not interpolated across a jump
        else:
            base = interpolate_pose(poses[0], poses[1], frame.stamp_ns)
        assert self.base_to_grid is not None
        return base.compose(self.base_to_grid)

    def _timing(self, frame: Frame) -> tuple[bool, float, bool]:
        """``(first, dt, restarted)`` of ``frame``: a gap longer than :data:`MAX_GAP_S` restarts (counted)."""
        first = self.prev_stamp_ns is None
        dt = FIRST_DT_S if self.prev_stamp_ns is None else (frame.stamp_ns - self.prev_stamp_ns) * 1e-9
        if dt > MAX_GAP_S:
            self.summary.filter_restarts += 1
            log.warning("gap of %.3f s before frame %d: restarting the filter", dt, frame.index)
            self.prev_pose = None
            return first, FIRST_DT_S, True
        if not first and dt < MIN_FRAME_DT_S:
            self.warn(
                "fast",
                "frame %d comes %.2f ms after the previous one (%.0f Hz), faster than a laser scans: the frames' "
                "clock does not time the scans, and the people motion model and the tracks' velocities are wrong. "
                'If the bag was written after the fact (record times in a burst), set time_source = "header" '
                "(pfpeople inspect chooses it for such bags)",
                frame.index,
                dt * 1e3,
                1.0 / dt if dt > 0 else math.inf,
                logger=log,
            )
        return first, dt, False

    def _jumped(self, frame: Frame, pose: Pose2D | None) -> bool:
        """Whether the odometry jumped from the previous pose to ``pose`` (restart; counted, warned once)."""
        if pose is None or self.prev_pose is None or self.prev_pose_stamp_ns is None:
            return False
        span = (frame.stamp_ns - self.prev_pose_stamp_ns) * 1e-9
        if not is_odometry_jump(self.prev_pose, pose, span):
            return False
        dyaw = math.atan2(math.sin(pose.yaw - self.prev_pose.yaw), math.cos(pose.yaw - self.prev_pose.yaw))
        self.summary.odometry_jumps += 1
        self.summary.filter_restarts += 1
        self.warn(
            "odojump",
            "topic %r: odometry jumps by %.3g m and %.3g rad in %.3f s before frame %d (faster than %g m/s "
            "or %.3g rad/s: a reset or relocalised odometry, not motion): restarting the filter there (such jumps "
            "are counted in odometry_jumps)",
            self.topic,
            math.hypot(pose.x - self.prev_pose.x, pose.y - self.prev_pose.y),
            dyaw,
            span,
            frame.index,
            MAX_ODOMETRY_SPEED_MPS,
            MAX_ODOMETRY_YAW_RATE,
            logger=log,
        )
        self.prev_pose = None
        return True

    def begin(self, frame: Frame) -> EgoMotion:
        """Time step, restart and odometry motion into ``frame`` (the state moves on at :meth:`end`)."""
        s = self.summary
        first, dt, restarted = self._timing(frame)
        pose = self.pose(frame)
        if self._jumped(frame, pose):
            restarted, dt = True, FIRST_DT_S
        odo: Odometry | None = None
        ego: Pose2D | None = None
        if self.topic:
            if pose is None:
                s.frames_without_odometry += 1
                self.warn(
                    "noodo",
                    "frame %d has no odometry within the tolerance: robot taken as standing (counted)",
                    frame.index,
                    logger=log,
                )
            elif self.prev_pose is not None:
                odo, lateral = odometry_between(self.prev_pose, pose, dt)
                s.max_lateral_m = max(s.max_lateral_m, abs(lateral))
        if pose is not None and self.prev_pose is not None:
            ego = self.prev_pose.inverse().compose(pose)
        return EgoMotion(dt=dt, first=first, restarted=restarted, pose=pose, ego=ego, odometry=odo)

    def from_laser(self, motion: EgoMotion, laser_ego: Pose2D | None) -> EgoMotion:
        """``motion`` with the controls of the scan-matched motion ``laser_ego`` (grid frame) when the run has no
        odometry topic, ``laser_odometry`` is on and the frame is not the first; else ``motion`` unchanged."""
        if self.topic or not self.laser_odometry or laser_ego is None or motion.first:
            return motion
        odo, lateral = odometry_between(Pose2D(), laser_ego, motion.dt)
        self.summary.laser_odometry_frames += 1
        self.summary.max_lateral_m = max(self.summary.max_lateral_m, abs(lateral))
        return replace(motion, odometry=odo, laser_ego=laser_ego)

    def end(self, frame: Frame, motion: EgoMotion) -> None:
        """Move on past ``frame``: a frame without odometry keeps the last pose, so its motion is not lost.

        The frame is counted in :attr:`RunSummary.ego_motion` by the source of ``motion.odometry``.
        """
        source = "none" if motion.odometry is None else "scan_matching" if motion.laser_ego is not None else "odometry"
        count(self.summary.ego_motion, source)
        self.prev_stamp_ns = frame.stamp_ns
        if motion.pose is not None:
            self.prev_pose = motion.pose
            self.prev_pose_stamp_ns = frame.stamp_ns
