"""Pluggable gaze sources: where is the viewer looking?

``gaze.factory.open_source(spec)`` builds a ``GazeSource`` (cursor, fixed point,
recorded trace or webcam estimator) whose ``sample(t)`` returns a ``GazeSample`` with
``x, y`` normalised to [0, 1]^2, origin top-left.  The package does not depend on the
renderer.
"""
