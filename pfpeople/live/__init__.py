"""pfpeople live: the transport-free core of a live node (messages in as they arrive, results out, every scan).

:class:`pfpeople.live.session.LiveSession` takes decoded messages (:class:`pfpeople.io.bag.reader.BagMessage`),
waits for the first of each sensor topic and TF to set the run up, then runs the streaming API
(:class:`pfpeople.pipeline.stream.PeopleStream`) on them and returns each frame's output messages (the result bag's
topics and types, :mod:`pfpeople.live.outputs`), drops the scans it cannot keep up with (counted) and measures each
scan's latency (:mod:`pfpeople.live.latency`). The ROS 1 node (:mod:`pfpeople.ros1`) is a thin adapter around it:
its transport decodes and encodes ROS 1 messages (:mod:`pfpeople.live.codec`); a ROS 2 adapter would decode and
encode CDR around the same session.
"""
