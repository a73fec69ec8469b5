"""What the lasers tell beyond people: the static-clutter map and stage, the robot's self returns, and ego-motion
from odometry or scan matching."""
